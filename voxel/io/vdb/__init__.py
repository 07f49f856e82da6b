"""``volume.vdb`` written without OpenVDB, streamed slab by slab.

Leaves cut from voxel rows (:mod:`~voxel.io.vdb._encode`), encoded and spooled
(:mod:`~voxel.io.vdb._leaves`), the file and its tree (:mod:`~voxel.io.vdb._format`), the
writer (:mod:`~voxel.io.vdb._writer`).
"""
