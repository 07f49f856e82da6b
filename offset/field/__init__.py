"""The field method's shells: the layer field meshed, its planar patches, their simplification.

- :mod:`~shellvox.offset.field.layer_field` samples the layer field (the exact nearest
  face of every node, :mod:`shellvox.voxel.geometry`) and marches it;
- :mod:`~shellvox.offset.field.marching_tets` marching tetrahedra on the node grid, with
  :mod:`~shellvox.offset.field.node_field` the field at its nodes and exactly along its
  edges;
- :mod:`~shellvox.offset.field.planar_patches` and
  :mod:`~shellvox.offset.field.patch_topology` planar patches triangulated again from
  their boundaries;
- :mod:`~shellvox.offset.field.simplify`, :mod:`~shellvox.offset.field.simplify_passes`
  the simplification within an error bound that makes no crossing, and
  :mod:`~shellvox.offset.field.heap` the allocator's settings around it.
"""
