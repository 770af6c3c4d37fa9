"""Render a packing and its force network from the ParaView files of ``forcespace view``
with VTK's own renderer, offscreen (no display needed).

Usage::

    forcespace view studies/packings/paper_mu0.1.h5 -o view_mu0.1 --format vtk
    python studies/render_viewer.py view_mu0.1 -o studies/out/viewer_paper_mu0.1.png

Reads ``disks.vtp``, ``contacts.vtp`` and ``walls.vtp`` with vtkXMLPolyDataReader (as
ParaView does); disks are circles of their radius (pale grey: rattlers), contacts are
ribbons of width proportional to the normal force (the largest 0.5 R), coloured by their
mobilisation |ft|/(mu fn) (blue 0 -> red 1: sliding), walls are dark bars.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _reader(path):
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    r = vtkXMLPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    return r


def render(directory, png, size=(1000, 1070)) -> Path:
    import numpy as np
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (registers the OpenGL backend)
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkLookupTable, vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkPolyData
    from vtkmodules.vtkFiltersCore import vtkCellDataToPointData, vtkGlyph3D, vtkTubeFilter
    from vtkmodules.vtkFiltersSources import vtkRegularPolygonSource
    from vtkmodules.vtkIOImage import vtkPNGWriter
    from vtkmodules.vtkRenderingCore import (vtkActor, vtkPolyDataMapper, vtkRenderer,
                                             vtkRenderWindow, vtkWindowToImageFilter)
    from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor

    d = Path(directory)
    ren = vtkRenderer()
    ren.SetBackground(1, 1, 1)
    # disks: a unit-diameter circle glyph scaled by the "diameter" point array, in two
    # sets (load-bearing, rattlers) so each gets its colour
    circle = vtkRegularPolygonSource()
    circle.SetNumberOfSides(48)
    circle.SetRadius(0.5)
    disks_rat = _reader(d / "disks.vtp").GetOutput()
    for rattler, colour in ((0, (0.78, 0.84, 0.95)), (1, (0.9, 0.9, 0.9))):
        pts = vtk_to_numpy(disks_rat.GetPoints().GetData())
        rat = vtk_to_numpy(disks_rat.GetPointData().GetArray("rattler"))
        dia = vtk_to_numpy(disks_rat.GetPointData().GetArray("diameter"))
        keep = rat == rattler
        sub = vtkPolyData()
        vp = vtkPoints()
        vp.SetData(numpy_to_vtk(np.ascontiguousarray(pts[keep] - [0, 0, 0.01]), deep=True))
        sub.SetPoints(vp)
        arr = numpy_to_vtk(np.ascontiguousarray(dia[keep]), deep=True)
        arr.SetName("diameter")
        sub.GetPointData().SetScalars(arr)
        g = vtkGlyph3D()
        g.SetInputData(sub)
        g.SetSourceConnection(circle.GetOutputPort())
        g.SetScaleModeToScaleByScalar()
        g.SetScaleFactor(1.0)
        m = vtkPolyDataMapper()
        m.SetInputConnection(g.GetOutputPort())
        m.ScalarVisibilityOff()
        a = vtkActor()
        a.SetMapper(m)
        a.GetProperty().SetColor(*colour)
        a.GetProperty().EdgeVisibilityOn()
        a.GetProperty().SetEdgeColor(0.45, 0.45, 0.45)
        ren.AddActor(a)
    # contacts: tubes of radius fn / max * 0.25 R, coloured by mobilisation
    contacts = _reader(d / "contacts.vtp").GetOutput()
    fn = vtk_to_numpy(contacts.GetCellData().GetArray("fn"))
    width = numpy_to_vtk(np.ascontiguousarray(0.25 * np.abs(fn) / np.abs(fn).max()), deep=True)
    width.SetName("width")
    contacts.GetCellData().AddArray(width)
    c2p = vtkCellDataToPointData()
    c2p.SetInputData(contacts)
    c2p.Update()
    shown = c2p.GetOutput()
    shown.GetPointData().SetActiveScalars("width")
    tube = vtkTubeFilter()
    tube.SetInputData(shown)
    tube.SetVaryRadiusToVaryRadiusByAbsoluteScalar()
    tube.SetNumberOfSides(8)
    tube.Update()
    out = tube.GetOutput()
    out.GetPointData().SetActiveScalars("mobilisation")
    lut = vtkLookupTable()
    lut.SetHueRange(0.66, 0.0)
    lut.SetTableRange(0.0, 1.0)
    lut.Build()
    m = vtkPolyDataMapper()
    m.SetInputData(out)
    m.SetLookupTable(lut)
    m.SetScalarModeToUsePointFieldData()
    m.SelectColorArray("mobilisation")
    m.SetScalarRange(0.0, 1.0)
    a = vtkActor()
    a.SetMapper(m)
    a.GetProperty().SetAmbient(1.0)
    a.GetProperty().SetDiffuse(0.0)
    ren.AddActor(a)
    bar = vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetTitle("|ft| / (mu fn)")
    bar.SetNumberOfLabels(3)
    bar.SetOrientationToHorizontal()
    bar.SetPosition(0.25, 0.01)
    bar.SetWidth(0.5)
    bar.SetHeight(0.07)
    for prop in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
        prop.SetColor(0, 0, 0)
        prop.ItalicOff()
        prop.ShadowOff()
    ren.AddViewProp(bar)
    # walls
    walls = _reader(d / "walls.vtp").GetOutput()
    wt = vtkTubeFilter()
    wt.SetInputData(walls)
    wt.SetRadius(0.25)
    wt.SetNumberOfSides(8)
    m = vtkPolyDataMapper()
    m.SetInputConnection(wt.GetOutputPort())
    m.ScalarVisibilityOff()
    a = vtkActor()
    a.SetMapper(m)
    a.GetProperty().SetColor(0.15, 0.15, 0.15)
    ren.AddActor(a)
    win = vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.AddRenderer(ren)
    win.SetSize(*size)
    cam = ren.GetActiveCamera()
    cam.ParallelProjectionOn()
    ren.ResetCamera()
    cam.Zoom(1.25)
    win.Render()
    grab = vtkWindowToImageFilter()
    grab.SetInput(win)
    grab.Update()
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    w = vtkPNGWriter()
    w.SetFileName(str(png))
    w.SetInputConnection(grab.GetOutputPort())
    w.Write()
    return png


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("directory", help="output directory of forcespace view (--format vtk)")
    ap.add_argument("-o", "--output", required=True, help="PNG to write")
    args = ap.parse_args(argv)
    print(render(args.directory, args.output))
    return 0


if __name__ == "__main__":
    sys.exit(main())
