"""Part programs several tests cut on the virtual lathe."""

# An outside profile of lines and arcs away from the spindle axis: a face-in, a cylinder,
# a fillet, a shoulder.
SHAFT = """%
O2000 (SHAFT)
G18 G21 G40 G98
T0101
G00 X90. Z10.
G01 X100. Z5. F200.
G01 Z-20.
G02 X140. Z-40. R20.
G01 X160.
G00 X200. Z50.
M30
%
"""
