"""Reference methods of shell offsetting, and the file preparation only they need.

- ``robust`` (:mod:`~shellvox.offset.reference.robust`): the union of convex pieces swept by
  every face (:mod:`~shellvox.offset.reference.pieces`, :mod:`~shellvox.offset.reference.planar`,
  :mod:`~shellvox.offset.reference.band`, :mod:`~shellvox.offset.reference.union`), cut and
  checked (:mod:`~shellvox.offset.reference.core_cut`, :mod:`~shellvox.offset.reference.guards`,
  :mod:`~shellvox.offset.reference.mesh_diff`): exact by construction, minutes on a scan;
- ``paper`` (:mod:`~shellvox.offset.reference.paper`): Zhu and Chen's three-plane construction;
- their shells made ready for files: :mod:`~shellvox.offset.reference.clean`,
  :mod:`~shellvox.offset.reference.clean_steps`, :mod:`~shellvox.offset.reference.jitter`,
  :mod:`~shellvox.offset.reference.for_file`.
"""
