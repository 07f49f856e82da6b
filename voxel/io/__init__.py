"""Serialisation of the stack: TIFF, PNG, GrabCAD jobs, OpenVDB, previews, deflate.

These modules import only :mod:`voxel.grid`, :mod:`voxel.colour.srgb` and each other.

- :mod:`~voxel.io._compression` every deflate stream's setting; :mod:`~voxel.io._deflate` a
  compiled run-length encoder (the VDB leaves) and a page's bytes;
- :mod:`~voxel.io._tiff_pages` pages encoded where a slab is computed;
  :mod:`~voxel.io._tiff_writer` the TIFF stacks; :mod:`~voxel.io._png_encode`,
  :mod:`~voxel.io._png_slices` PNG slices; :mod:`~voxel.io._gcvf_job`,
  :mod:`~voxel.io._gcvf_writer` GrabCAD Voxel Print jobs; :mod:`~voxel.io._slab_thread` the
  writer thread they share;
- :mod:`voxel.io.vdb` ``volume.vdb`` without OpenVDB; :mod:`~voxel.io._preview` section
  pictures and the depth histogram.
"""
