"""The stages several pipelines share, each module named for what it holds.

``aids`` (a log loaded into arrays, the filter's aids and its run on them), ``start`` (still
intervals, the static period, the start position, the alignment on the move), ``turntable_tilt``
(the base tilt of a rotating IMU's turntable axis), ``ldv_mounting`` (the LDV mounting, compliance
and scale, estimated or given), ``plumb_line`` (the deflection of the vertical in the mechanization)
and ``grid_cache`` (the DOV grid cache a caller may provide).
"""
