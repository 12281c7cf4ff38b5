"""`impactnet bench`: the speed-accuracy trade of every way of answering, measured in one run.

One folder per thing measured; the plumbing of the main run stays here.

Here (the main run and what every folder shares)
------------------------------------------------
cli         CLI glue of ``impactnet bench`` and of each of its subcommands
runner      the run: pose sets, every method on each, the paper check, optional HTTP
measure     the measurement plan (BenchConfig) and one method on one pose set
methods     every method behind one interface: exact, FCL Box-Box, polygon n, learned
pose_sets   the scene's first-contact poses and the paper's Figure 2 hard case
contact_sets  stacking and edge-on-edge pose recipes (the comparisons with MuJoCo)
timing      one-core timing helpers and the machine record
markdown    a number to a few significant digits and the machine line, for every report
report      Markdown tables and JSON of the main run
plots       the Pareto plot, the polygon sweep against n, Figure 2 errors against the tilt
datagen     throughput of labelled data generation (``python -m``, a benchmark of its own)

Folders (what they measure)
---------------------------
accuracy/   errors against references: the exact solver, MuJoCo's box-box, the grid centre of
            pressure; the stacking table
paper/      the paper's polygon method and its Section II grid estimate
exact/      ``impactnet bench exact``: the exact solver's speed next to python-fcl, and this
            checkout against an earlier one
speed/      speed as ratios against MuJoCo called from Python, and the per-stage profile
            (``impactnet bench speed``; the speed section of the report)
frame/      ``impactnet bench frame``: a frame in one call, its scaling, against MuJoCo
compound/   ``impactnet bench compound``: the compound oracle's cost against detail, next to
            FCL and MuJoCo
learned/    the learned paths against the exact answers: ``bench decide`` (box pairs),
            ``bench moe`` (compound pairs), the classifier probes
http/       through the HTTP service on loopback: ``bench --http``, ``bench moe --http``,
            ``bench hostile``, and the service's latency and throughput (``service_speed``)

Nothing here is imported by the package itself, so importing ``impactnet.training.bench`` stays
cheap.
"""
