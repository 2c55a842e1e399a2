"""The FreeCAD Path post-processor for FANUC lathes (``postproc_fanuc_lathe_post.py``)."""
