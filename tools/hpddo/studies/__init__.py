"""Measurements built on the pipeline: the paper's comparison with its peers (compare), the
figures on never-seen recordings (validation), the novelty gate's study (gate_study), the
ripple speed's figures on the twin (ripple), why the residual follows dV/dt on a fast twin recording
and the dynamic family identified there (dynamics), and the benchmarks of the observer step on every
target (perf).

May import: everything below the command line (the foundations, logs, model, evaluation,
twin, diagnosis, reports, hpddo.pipeline); not hpddo.cli.
"""
