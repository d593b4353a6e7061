"""Reading and writing: bench logs (benchlog: the format of docs/bench-log.md; dataset:
a log cleaned and split into a recording), output folders that never lose a user's file
(outdir), the ripple bursts beside a bench log (ripple: the high-rate current of the
ripple mode), and the errors a user's input can cause (errors).

May import: the foundations (hpddo.schema, hpddo.bench, hpddo.interrupt) and nothing else of hpddo.
"""
