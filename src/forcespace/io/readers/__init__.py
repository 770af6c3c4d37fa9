"""Readers of measured frames: force networks from experiments and other codes, each into
a :class:`~forcespace.model.packing.Packing` carrying a
:class:`~forcespace.model.measurement.Measurement` (which forces are data, their
uncertainty, the source files and their hashes, units, pixel scale, conventions).

* :func:`read_csv_pair` -- ``particles.csv`` + ``contacts.csv``, the documented plain
  format (:mod:`.csv_pair`);
* :func:`read_pegs` -- one PeGS frame in the matrix layout: ``*_ParticleData.dlm`` and the
  Norm / Tan / Binary weighted adjacency matrices, in pixels with a user scale;
* :func:`read_pegs2` -- one frame of PeGS2's own files: the adjacency list
  (``*_Adjacency.txt`` or ``Adjacency_list.txt``) and ``particle_positions.txt`` (or a
  ``*_centers.txt``), in pixels with a user scale (both :mod:`.pegs`);
* :func:`read_lammps_dump` -- LIGGGHTS / LAMMPS ``dump local`` of ``compute
  pair/gran/local`` with the atom dump (:mod:`.lammps`).

Each refuses a bad input with one line naming the file, the field and what is allowed,
before any analysis. The writers (``write_csv_pair``, ``write_pegs``, ``write_pegs2``,
``write_lammps_dump``) write forcespace's own packings in each format (exports, tests).
"""
from .csv_pair import read_csv_pair, write_csv_pair
from .lammps import read_lammps_dump, write_lammps_dump
from .pegs import read_pegs, read_pegs2, write_pegs, write_pegs2

FORMATS = ("csv", "pegs", "pegs2", "lammps")

__all__ = ["read_csv_pair", "read_pegs", "read_pegs2", "read_lammps_dump", "write_csv_pair",
           "write_pegs", "write_pegs2", "write_lammps_dump", "FORMATS"]
