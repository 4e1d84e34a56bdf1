"""Closed-loop rigs: a plant, its controller, references, disturbances and loggers wired into one
Drake diagram that is built once and flown many times (designs compared, parameters tuned).

Each module holds the rig of one family of plants; they build on :mod:`sobolev_drake.harness`.
"""
