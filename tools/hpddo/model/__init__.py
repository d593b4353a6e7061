"""What a model is, how it is fitted, and how it reaches the boards: the physics (physics,
its float32 libm), the effect library (effects) and its identification (identify), the
residual network (network) and its training (train), the novelty gate (gate), fixed
point (quant), the float and integer references of the board observer (observer_ref), the
reference of the dynamic family's observer on the boards (dynamics_ref, hpddo/dynamics.h),
the model headers and golden vectors (export), the core's test models (fixtures), the speed
counted from the commutation ripple (ripple, docs/ripple.md), and the speed the fits take as
rpm_ref: the encoder's or the ripple's (reference).

May import: the foundations (hpddo.schema, hpddo.bench, hpddo.interrupt) and hpddo.logs.
"""
