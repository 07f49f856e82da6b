"""``volume.vdb`` written without OpenVDB, streamed slab by slab.

Leaves cut from voxel rows (:mod:`~voxel.io.vdb.encode`), encoded and spooled
(:mod:`~voxel.io.vdb.leaves`), the file and its tree (:mod:`~voxel.io.vdb.format`), the
writer (:mod:`~voxel.io.vdb.writer`).
"""
