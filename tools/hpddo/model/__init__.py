"""What a model is, how it is fitted, and how it reaches the boards: the physics (physics,
its float32 libm), the effect library (effects) and its identification (identify), the
residual network (network) and its training (train), the novelty gate (gate), fixed
point (quant), the float and integer references of the board observer (observer_ref), the
reference of the dynamic family's observer on the boards (dynamics_ref, hpddo/dynamics.h),
the model headers and golden vectors (export) and the core's test models (fixtures). The speed
counted from the commutation ripple, and the reference the fits take, are a room above
(hpddo.ripple).

May import: the foundations (hpddo.schema, hpddo.bench, hpddo.interrupt) and hpddo.logs.
"""
