"""Every tolerance and threshold of forcespace, named once, with its unit and reason.

Units: ``<Fn>`` is the mean jammed normal force of a statics problem
(``StaticsProblem.force_scale``); forces are compared with it after the problem
is scaled to <Fn> = 1 (HiGHS' tolerances are absolute). ``R`` is the smallest
radius of the scene's range. ``1`` marks a pure number.

Modules read these as ``config.NAME`` at call time, so a benchmark may change a
threshold (e.g. force the sparse path on a small problem) for one run.
"""

# ---- contacts and packings -----------------------------------------------------------
FORCE_BEARING = 1e-9        # [<Fn>] a contact with fn above this carries load; a disk with
                            # no such contact is a rattler (excluded from z and from S)
FN_ROUND_OFF = 1e-6         # [1] a stored normal force below -FN_ROUND_OFF x mean |fn| is
                            # tension (a file edited or negated), not the solver's round-off
UNIT_NORMAL_TOL = 1e-6      # [1] a stored contact normal whose length is further from 1 is
                            # not a unit vector (files store normals to full precision)

# ---- making packings (engine) ------------------------------------------------------------
STATIC_RETRIES = 3          # [compressions] further compressions after a failed static solve
                            # (a configuration that only looked at rest: a creep paused for
                            # a window); then the exact LP of S decides
UNSETTLE_WINDOWS = 10       # [windows] the rest test is suspended for this many windows
                            # before each retry, so the creep shows again

# ---- measured networks (readers, frames, check) ------------------------------------------
CONTACT_GAP_TOL = 0.1       # [1] a reader refuses a listed contact whose surface gap or overlap
                            # exceeds this x the smaller radius of the pair (0.1 r: an image's
                            # detection error of a few pixels on 30-pixel disks; DEM overlaps
                            # are < 1e-2 r): the two particles do not touch
CONTACT_NORMAL_TOL = 0.05   # [rad] a contact normal given in the data may differ this much from the
                            # centres' direction (which defines it); more: reversed or another frame
UNKNOWN_SIGMA = 1e3         # [<Fn>] uncertainty given to a contact whose force was not measured
                            # when the nearest admissible network is sought (practically free)
SIGMA_FLOOR = 1e-3          # [1] a measurement uncertainty below this x the median is raised to it
                            # (two equal estimates of a contact would weigh it infinitely)
LOAD_ROUND_OFF = 1e-9       # [<Fn>] measured loads on a region's disks that no network can
                            # balance (A x = b inconsistent) by more than this are data, not
                            # round-off: S is empty and the smallest relaxation is reported
MEASURED_VIOLATION = 1e-9   # [<Fn>] a measured contact violates Coulomb (|ft| > mu fn or
                            # fn < 0) when it does by more than this

# ---- linear algebra of S (ranks, null spaces) ------------------------------------------
RANK_TOL = 1e-10            # [1] singular value s counts when s > RANK_TOL * s_max * max(shape)
                            # (numpy's matrix_rank rule with a cut-off above round-off of
                            # assembled equilibrium rows, ~1e-14 relative)
RANGE_RANK_TOL = 1e-11      # [1] the same rule for the row space of the projection's active
                            # equalities (rows dependent up to round-off must not be amplified)
SWEEP_MIN_COLUMNS = 1500    # [columns] from this size: sparse frontier sweep instead of a dense
                            # SVD, interior-point LPs first, LU circuits (dense paths keep the
                            # paper-sized slices, ~400 columns, bit for bit as before)
SWEEP_MARGIN = 100.0        # [1] a sweep whose rank decision came within this factor of its
                            # threshold is redone by the dense SVD
SWEEP_CHUNK_ROWS = 96       # [rows] per sweep step (96 measured 2x faster than 48 at 5000 disks)
SWEEP_LIVE_TOL = 1e-12      # [1] a null vector with frontier weight below this is final
PIVOT_TOL = 1e-9            # [1] a pivot (|diagonal| of a pivoted QR or LU of null-space rows)
                            # below this x the largest is a dependent direction, not a basis
                            # column (elementary clusters and their circuits)
NEW_DIRECTION_TOL = 1e-6    # [1] a circuit adds a direction to a domain's basis when its part
                            # outside the chosen ones exceeds this x its norm
MOVING_ROW_TOL = 1e-10      # [1] a column whose null-space row has a smaller norm is constant
                            # on S's affine hull (no range LP asked for it)

# ---- the exact analysis of S (LPs) -------------------------------------------------------
IMPLICIT_TOL = 1e-9         # [<Fn>] an inequality whose slack never exceeds this on S is an
                            # implicit equality (a contact forced to slide or to carry nothing)
VARY_TOL = 1e-6             # [<Fn>] a contact varies in S if its fn or ft can change by more
                            # than this within S
RANGE_GAP_TOL = 1e-4        # [<Fn>] a range LP's answer is reported when its multipliers prove
                            # no point of S beyond it by more than this (the bound's own slack,
                            # |N^T q| x the diameter bound of S, stays below 5e-5 on n = 800,
                            # mu = 1 slices; the simplex's wrong answers were 0.03-0.2 short)
RANGE_LP_TOL = 1e-10        # [<Fn>] primal and dual feasibility of the warm-started simplex
                            # LPs of the per-contact ranges of large problems (HiGHS' smallest)
RANGE_EXACT_MAX_DIM = 1000  # [dimensions] up to this dim S, each warm-started range LP's optimum is
                            # polished to its exact vertex (dense d x d solves; HiGHS' basis,
                            # optimal to its 1e-10, left ends ~1e-9 <Fn> off the optimum)
RANGE_FLAT_ROW = 1e-13      # [1] |G_i N| below this: row i is constant on S's affine hull and left
                            # out of the range LPs (FLAT_ROW, 1e-9, would let a row still
                            # varying at 1e-9 <Fn> widen a range by that much)
HULL_RANGES_MAX_DIM = 4000  # [dimensions] up to this dim S, the per-contact ranges of a large
                            # problem (SWEEP_MIN_COLUMNS and up) are asked in the affine hull's
                            # coordinates (dense rows x dim S: 4000 x 4000 doubles = 128 MB)
SIMILAR_ORDER_MAX_WORK = 2e10  # [flops] of the greedy nearest-direction order of the range LPs
                            # (1000-disk frame: 2e8); above, a cheaper order (leading direction)
REDUCED_LP_MAX_DIM = 200    # [dimensions] up to this dim S, the range LPs of the varying test
                            # are asked in the affine hull's d coordinates, not the 2m forces
UNBOUNDED_TOL = 1e-7        # [1] recession-cone LP optimum above this: S is unbounded
INTERIOR_TOL = 1e-10        # [<Fn>] feasibility/optimality of the interior-point LPs without
                            # crossover that large analyses use (SWEEP_MIN_COLUMNS and up)
INTERIOR_SOLVERS = {"strict_rows": "clarabel", "max_sum_fn": "highs-ipm",
                    "centre": "highs-ipm"}
                            # the interior point of each of those LPs ("clarabel" or
                            # "highs-ipm"), the faster measured on the 5000-disk slice (CPU s,
                            # HiGHS / Clarabel): strict rows 7.9 / 0.53, max sum fn 4.6 /
                            # 5.7, centre 9.6 / 17.8 (studies/sampler_cost.md, issue 46)
INTERIOR_CAP = 1e-5         # [<Fn>] slack cap of the one interior-point LP that finds the rows
                            # strict somewhere in S: a cap below every row's largest slack in a
                            # common point makes that point optimal (one solve decides all;
                            # 5000-disk slice: smallest such slack 4e-5)
INTERIOR_STRICT = 1e-8      # [<Fn>] slack that proves a row strict at the interior point: 100x
                            # INTERIOR_TOL; rows below it go to the exact (simplex) test
CIRCUIT_TOL = 1e-6          # [1] entries of a fundamental circuit below this x its largest are
                            # round-off couplings, not support
SUPPORT_TOL = 1e-7          # [1] entries of an L1-minimal circuit below this x its largest
                            # are round-off, not support
RECESSION_SUPPORT_TOL = 1e-9  # [1] entries of a recession direction of S below this x its
                            # largest are round-off (its reported support)
TRUSTED_POINT = 1e-2        # [VARY_TOL] a point of S that spares range LPs violates S by at
                            # most this x the range tolerance (HiGHS' optima can miss S by
                            # 1e-6 <Fn> on ill-conditioned slices, mu = 10)
HULL_CENTRE_MAX_COLUMNS = 6000  # [columns] above: no centre of S's affine hull by the dense
                            # least-squares fallback (it solves the equalities densely)

# ---- projection onto S ------------------------------------------------------------------
KKT_TOL = 1e-9              # [1] stationarity residual (relative) that verifies a projection
ACTIVE_TOL = 1e-7           # [<Fn>] rows this close to tight start the active-set polish
POLISH_FEASIBLE = 1e-11     # [<Fn>] a polished point violating a row by more adds it
QP_TOLS = (1e-11, 1e-9, 1e-8)  # [<Fn>] duality gap and feasibility of the interior-point
                            # projection (Clarabel) of a measured network onto S, tried in turn:
                            # the tightest ended in "insufficient progress" on 1 of 16 quick
                            # noisy frames; each answer is checked to SAMPLE_VIOLATION anyway
QP_KKT_TOL = 1e-7           # [1] its stationarity residual with the solver's multipliers,
                            # relative to max(|x - x_measured|, <Fn>), that verifies it
SLIDE_TOL = 1e-9            # [<Fn>] selection: a Coulomb row with less slack is active
TIGHT_TOL = 1e-9            # [<Fn>] a row of S with less slack is tight when the KKT residual of
                            # a projection is checked (a larger violation: not a projection)
LDP_INFEASIBLE = 1e-14      # [1] the least-distance problem's NNLS residual component below
                            # this: the constraints are infeasible (Lawson-Hanson's test)

# ---- sampling ------------------------------------------------------------------------------
SAMPLE_VIOLATION = 1e-9     # [<Fn>] every stored sample violates S by at most this (checked)
FLAT_ROW = 1e-9             # [1] |G_i N| below this: row i is constant on S's affine hull
FRAME_MARGIN = 1e-8         # [<Fn>] slack the walks start with in a frame widened because S had
                            # no point strictly inside in its affine hull (sampling.frame)
FRAME_MAX_WIDENING = 1e-6   # [<Fn>] a frame needing a wider move of its rows is refused: VARY_TOL,
                            # the force difference below which the analysis says a contact
                            # does not vary in S (size study: misses of 1.6e-8 and 1.2e-7)
SPREAD_FLOOR = 1e-8         # [<Fn>] rms spread per contact below which S is numerically a
                            # point (no Fig. 3 ratio of two round-off numbers)
ROUNDING_ROW_TOL = 1e-10    # [1] rows of the slack-scaled {A x <= 1} below this x the largest
                            # row norm never bind (contacts that do not vary in S)
ROUNDING_MIN_CLEARANCE = 1e-3  # [1] a rounding ellipsoid that must shrink by more than this
                            # factor to fit inside the polytope (its centre on a facet up to
                            # round-off, or not positive definite) is rejected, not used
ROUNDING_CENTRED = 1e-3     # [1] Newton decrement at which the John rounding's centre is found
LEWIS_CENTRED = 1e-6        # [1] half the squared Newton decrement at which the billiard walk's
                            # Lewis rounding counts its centre as found (exact line search:
                            # 10-15 Newton steps from the Chebyshev centre at dim 1714)
LEWIS_CENTRED_LARGE = 1e-2  # [1] the same on the large path (SWEEP_MIN_COLUMNS columns and up):
                            # dim 1714, 0 weight updates: 6 Newton steps instead of 8, John
                            # excess 5.1681 against 5.1678 (the frame as round)
BILLIARD_BURN_IN_LARGE = 20 # [trajectories] the billiard walk's default burn-in per chain on the
                            # large path (50 below): at dim 1714 |w|^2 reaches its stationary
                            # spread after 2-3 trajectories from the dispersed starts, tau
                            # (from the third quarter's states) was 115 with 50; the run's
                            # R-hat <= 1.05 still decides (50 x 4 were 6.3 CPU s there)
LEWIS_UPDATES_LARGE = 0     # [updates] the billiard walk's default Lewis-weight updates on the
                            # large path (5 below): at dim 1714 the Dikin ellipsoid at the
                            # analytic centre cost 0.059 CPU s per effective sample against
                            # 0.051 after 5 updates, which cost 24 CPU s more (sampler_cost.md)
MAX_GRAM_BYTES = 4e9        # [bytes] largest Gram matrix K = H H^T the billiard walk keeps
                            # (p <= ~22 000 rows); above, rows of K are computed per reflection
MVE_MAX_ROWS = 1500         # [rows] above: John (Lewis-weight) rounding, not the exact MVE
# ---- sampler option limits (a run past them would not end in any useful time: refused
# before any work, as -n 1e20 or --thin 1e12 ran until killed)
MAX_SAMPLES = 10 ** 8       # [samples] -n of any sampler (the studies draw <= 10^5)
MAX_CHAINS = 10 ** 4        # [chains] (the defaults: 4, relax 1)
MAX_HAR_THIN = 10 ** 9      # [steps] hit-and-run steps between samples (default dim S^2:
                            # 3e6 at dim 1714); ~10^4 s per sample at the 5000-disk slice
MAX_HAR_BURN_IN = 10 ** 10  # [steps] hit-and-run burn-in per chain (default 10 dim S^2)
MAX_BILLIARD_THIN = 10 ** 6     # [trajectories] between billiard samples (default 1)
MAX_BILLIARD_BURN_IN = 10 ** 7  # [trajectories] billiard burn-in per chain (default 50)
RELAX_STALL_SWEEPS = 20_000  # [sweeps] relax walk: no 1 % progress in this many is a stall
RHAT_MAX = 1.05             # [1] chains whose split R-hat (rank-normalised, folded) exceeds
                            # this on any tracked statistic have not mixed
MIN_ESS = 100.0             # [samples] effective sample size a converged run reaches on every
                            # tracked statistic (bulk and tail): the default target of
                            # diagnostics.converged and the studies' rule 4
N_PROJECTIONS = 4           # [statistics] random projections tracked besides |x - mean|^2 (a
                            # walk stuck along one direction shows in some projection)
STORED_SAMPLE_SLACK = 1e-6  # [1] a stored sample re-checked on reading may violate S by this
                            # much more (relative) than recorded: BLAS round-off of another
                            # thread count, not a changed file
MIN_DRAWS_PER_CHAIN = 100   # [samples] a target-ESS run stops no earlier: ESS estimated from
                            # shorter chains runs high (dim 1344: ESS "100" after 50 draws per
                            # chain was 77 on the longer run)
BILLIARD_MIN_DRAWS_PER_CHAIN = 25  # [samples] the same for the billiard walk (0.6-0.8 effective
                            # samples per draw): on prefixes of long runs (dim 228: 6 runs of
                            # 4 x 500 draws; dim 1714: 4 x 250) this rule stopped at 160-252
                            # samples, where the long runs' own ESS per draw gives 110-182
                            # (never below the target of 100; the short-chain estimates were
                            # 100-162, i.e. low, not high; at dim 1714 R-hat <= 1.05 decided)

# ---- files ---------------------------------------------------------------------------------
FORCE_MATCH_TOL = 1e-9      # [<Fn>] an ensemble's jammed forces and its packing's differ by at
                            # most this when the ensemble belongs to the packing

# ---- point force ----------------------------------------------------------------------------
DISPLACED = 0.1             # [R] a disk moved by more than this took part in a rearrangement
FLOOR_LAYER = 2.0           # [R] a disk whose lowest point lies less than this (the smallest
                            # diameter) above the floor is in the bottom layer: no disk fits
                            # under it, so a rearrangement that reaches it is cut off by the
                            # floor (censored)
