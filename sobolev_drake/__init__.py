"""sobolev_drake: robust control in weighted Sobolev spaces on Drake's systems framework.

Subpackages
-----------
synthesis    controller design (pure maths: LMIs, Riccati equations, Galerkin)
systems      Drake LeafSystems (controllers, allocation, propellers, aerodynamics, wind, ...)
models       plant builders: URDF -> MultibodyPlant wrapped as :class:`MechanicalModel`
experiments  the thesis experiments, composed from the above
"""

__version__ = "0.1.0"
