"""Bundle I/O: the ``ldv-drive-log/1`` formats, ``.gdf`` grids and CSV report writers."""
