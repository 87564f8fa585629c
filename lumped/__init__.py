"""Reduced (lumped) beam-and-spring model of the pedicle and the joint (docs/lumped.md §3).

Vectorised over designs: arrays of moduli in, arrays of α and β out. The same
equations build the CasADi expressions that ``calibration`` fits.
"""
