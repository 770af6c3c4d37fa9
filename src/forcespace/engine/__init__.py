"""The reference engine that makes packings: rigid-disk contact dynamics (Moreau-Jean time
stepping, nonlinear Gauss-Seidel with Coulomb friction) in numba kernels, the jamming
protocol, the frozen-network relaxation and the point-force push.

Modules, from the kernels up (each kernel sits behind a public function that validates
and shapes its arguments; kernels take the named records of ``records``):

* ``records``    -- the named state of the kernels (bodies, box, contacts, settings, stats)
* (random streams: :mod:`forcespace.streams`, every stream of the library in one place)
* ``contacts``   -- contact detection (cell list): :func:`contacts.detect_contacts`
* ``nlgs``       -- the Gauss-Seidel contact solver: :func:`nlgs.solve`
* ``step``       -- Moreau-Jean time steps: :func:`step.run_steps`
* ``frozen``     -- relaxation of a frozen network (static solve, relax walk): :func:`frozen.relax`
* ``bodies``     -- a setup's loose start, body arrays and kernel settings (from the records
  of :mod:`forcespace.model.setup`, made once from the scene by ``protocol``)
* ``compress``   -- compression until jammed, checkpoints (:mod:`forcespace.io.checkpoint`)
* ``static``     -- the static solve of the jammed configuration
* ``protocol``   -- the whole protocol: :func:`protocol.build_packing`, :func:`protocol.jam`
* ``interrupts`` -- Ctrl-C honoured between kernel calls
* ``push``       -- a point force on a settled layer
"""
