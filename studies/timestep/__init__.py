"""Time-step convergence of the gas studies: the collision map and the gas's energy drift.

    .venv/bin/python -m studies timestep                       # the full study (~17 CPU-min)
    .venv/bin/python -m studies timestep --pairs 100 --no-gas  # a quick look (~1 CPU-min)

The committed results/timestep/timestep.json (see its "argv") came from
    --factors-of trimer=0.0625,0.25,0.5,1.0,1.5,2.0 --bias 400,8 --bias-factors 0.5,1.0,1.5 --workdir DIR
(`--workdir` keeps every run; a repeated invocation reuses them, so parts can run in parallel).

The issue asks for D and the energy drift at dt factors 0.25, 0.5 and 1.0 (dt = factor x
r_min sqrt(rho/E)), and for the largest factor whose D differs from the smallest factor's by
under 0.2 %.  D itself cannot be resolved to 0.2 % by brute force (one 400 s run has sd 1.5-3 %).
In a dilute gas D depends on dt only through the outcome of each binary collision (free flight
is exact for the isotropic route and second order for delValle2023), so this script measures
the **collision map** directly, with common random numbers:

1. **Collision map** (``--pairs`` collisions per shape): pairs of clumps on collision courses
   drawn from the gas in equilibrium at ``energy_per_particle`` (relative velocity from the
   collision-flux-weighted Maxwellian, impact parameter uniform over the disc of radius twice the
   bounding radius, uniformly random orientations, equipartition spin), all pairs of one shape in
   one YADE scene far apart (``studies/timestep/collisions_yade.py``), run at each dt factor
   with the *same* pairs.  Per factor: the error of the momentum transfer, of the spin
   angular-momentum transfer and of the energy per collision against the finest factor (and
   the observed order of convergence), and the collision integral that sets D in the first
   Chapman-Enskog (Mason-Monchick) approximation, Omega ~ <g^2 q> over collisions,
   q = 1 - g'.g/g^2 (= 1 - cos chi for collisions that keep |g|): D ~ 1/Omega, so
   delta D/D = -delta Omega/Omega.  The same for <1 - cos chi> (the issue's quantity).  A time
   step that biases the translational/rotational energy exchange shifts the translational
   temperature of the gas; that shift is estimated from the map too (the bias per collision over
   the restoring rate, obtained by reweighting the same collisions to a slightly hotter
   translational temperature) and enters D as half of it.
2. **Energy drift of the gas**: small periodic gases through the study engine
   (``python -m studies sweep``), one group per dt factor, for each shape.

Shapes: the paper's dimer (d = 0.1333 m, D = d/2) as the study builds it (appendClumped, exact
mass, isotropic I_perp, aspherical=False) on YADE 2023.02a; the triangle trimer at overlap 0.5
as an aspherical clumpprops clump on YADE 2025.2 with rotAlgorithm='delValle2023' (Debian 13
root, ``scripts/debian13.sh``).  Prints tables, writes ``results/timestep/timestep.json``.
Method and results: docs/timestep.md.

Modules: ``collisions`` (drawing the collision courses, running them in YADE through
``collisions_yade``, the outcome of each collision), ``analysis`` (the tables of one shape's map,
the phase-stratified energy bias), ``gas`` (the energy drift of small gases through the study
engine) and ``study`` (the command line, ``python -m studies timestep``, its tables and decision).
"""
