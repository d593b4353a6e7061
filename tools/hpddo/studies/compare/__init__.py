"""The paper's comparison as one command (hpddo compare, docs/compare.md).

    hpddo compare LOG... --out DIR [--validation LOG...] [--effects NAME,...] [--quick]

On any set of labelled recordings, every method sees V and I (and temp_C where it uses
it) at run time and is identified, trained and tuned on the training rows only:

* M1 (nameplate), M2 (identified Ke; and with named effects, --effects), M3 (the
  residual network, clamp and envelope) and M3 with the novelty gate: the board observer,
  replayed natively (host/replay.cpp) on the chronological split and the never-seen
  recordings; elsewhere its rules in float64 (train.correction), which agree with the
  replay to the figure the tables show (the agreement is measured and written);
* the EKF and the sliding-mode observer (host/compare/observers.h), friction identified
  by steady-state torque balance and their parameters grid-tuned on the training rows,
  which are the only rows the tuner is given (a log of them alone);
* the pure network: M3's architecture and training, mapping (V, I, I(t-1), V(t-1)) to
  speed, replayed in float32 by the same native tool;
* the lookup baseline (mean training speed of the nearest training operating point).

Tables (each a JSON file and a table of OUT/report/index.html, with the paper's figures
beside ours): 7, RMSE per condition for every method, chronological and never seen
(--validation recordings, and leave one recording out); 8, shuffled 5-fold
cross-validation against the chronological split; 9, the architecture ablation; 10,
the feature ablation; ood, the out-of-distribution stress test of section 4.10 with the
eq. 26 bound checked on every sample.

The networks are trained as network.train trains M3 (the same initialisation, epochs,
batches, gradients and Adam steps), several of one architecture in lockstep with BLAS
matrix products (network.train_lockstep): network.train fixes its order of summation so that a
committed model header is the same bytes everywhere, and pays Python's cost once per
step and network; a comparison of 25 networks needs the speed more than the bytes. The
figures therefore move in their last digits with the CPU and the BLAS kernel
(docs/compare.md gives the tolerance).

The parts: config (settings, the paper's figures), methods (the compared methods' inputs), training
(the networks), observers (the native EKF, SMO and pure network), tables (7-10 and the
out-of-distribution test), run (the whole comparison), text (the printed summary and docs/compare.md).

May import: see hpddo.studies.
"""
from .config import CompareConfig  # noqa: F401
from .run import Comparison, run  # noqa: F401
from .text import command_line, markdown, text_summary  # noqa: F401
