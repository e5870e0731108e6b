"""Simulated false-alarm rate of the paper-scale t10 verdict set (issue 48, item 1).

Draws the 36 end-of-loading t10 points of `config/paper.yaml` (copper ore, limestone, granulite x
single impact and drop weight x 6 energies, 100 particles of 29 mm) from the Tavares model itself:
each particle's fracture energy (eqs 1-3; it breaks when E <= e Ek/m), eq 8's t10' on the family
grid, a progeny family drawn by its probability and the mass its dummy share puts through d/10
(eq 11). Each point gets the verdict's p-value, the points of a set are combined by Bonferroni and
the 6 sets decided by Holm at 5 %, as `millsim.analysis.tavares_verification` does; a replicate
fails when any set is rejected. Prints the running count.

    python tools/t10_false_alarm.py --replicates 150            # the Monte Carlo p (the verdict's)
    python tools/t10_false_alarm.py --replicates 1500 --normal  # a normal z with the model's spread
    python tools/t10_false_alarm.py --bootstrap                 # per point, the bootstrap interval's z
"""

import argparse

import numpy as np
from scipy import stats

from millsim.analysis.tavares_verification import bonferroni, holm
from millsim.models.breakage import progeny_families as pf
from millsim.models.breakage import tavares as T
from millsim.models.breakage import tavares_predictions as tp
from millsim.models.breakage.tavares_materials import load_materials

DIAMETER = 0.029
RATIOS = (0.5, 1.0, 2.0, 3.0, 5.0, 8.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=150)
    ap.add_argument("--normal", action="store_true", help="normal z with the model's spread")
    ap.add_argument("--bootstrap", action="store_true",
                    help="rejection rate at 5 %% of one point (0.5 x E50, ~25 broken) with the "
                         "z read from a 95 %% percentile bootstrap interval, 400 draws per material")
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args(argv)
    if args.bootstrap:
        return bootstrap_rates(np.random.default_rng(1))
    mats = load_materials(truncation="single_particle")
    rng = np.random.default_rng(args.seed)
    points, tables = [], {}
    for name in ("copper_ore", "limestone", "granulite"):
        m = mats[name]
        share = tp.absorbed_share(m)
        for r in RATIOS:
            Ek = r * tp.stressing_median(m, DIAMETER, share)
            points.append((m, Ek, share, tp.t10_expected(m, DIAMETER, Ek, share),
                           tp.t10_spread(m, DIAMETER, Ek, share)))

    def product(m, Ek, share, n=100):
        absorbed = Ek * share
        E = T.sample_fracture_energy(m, DIAMETER, rng.random(n))
        out = []
        for t in np.clip(T.t10_prime(m, absorbed, E[E <= absorbed]), T.T10_STEP, m.A):
            g = pf.t10_grid(t)
            if (m.name, g) not in tables:
                tab = pf.families(m, g)
                tables[m.name, g] = (100 * tab.fractions[:, -1] * float(T.fines_passing(g, 0.1, m)),
                                     tab.probabilities / tab.probabilities.sum())
            per, prob = tables[m.name, g]
            out.append(per[rng.choice(len(prob), p=prob)])
        return np.array(out)

    fails = 0
    for k in range(1, args.replicates + 1):
        sets = []
        for _mode in range(2):
            for i in range(3):
                ps = []
                for m, Ek, share, mean, spread in points[6 * i:6 * i + 6]:
                    x = product(m, Ek, share)
                    if not x.size:
                        ps.append(np.nan)
                    elif args.normal:
                        z = abs(x.mean() - mean) / (spread / np.sqrt(x.size))
                        ps.append(2 * stats.norm.sf(z))
                    else:
                        ps.append(tp.t10_p_value(m, DIAMETER, Ek, share, x.mean(), x.size,
                                                 draws=20_000, seed=k, grid=20_000))
                sets.append(bonferroni(ps))
        rejected, _ = holm(sets)
        fails += any(rejected)
        ci = stats.binomtest(fails, k).proportion_ci()
        print(f"{k} replicates, {fails} failed: {fails / k:.3f} [{ci.low:.3f}, {ci.high:.3f}]",
              flush=True)


def bootstrap_rates(rng, draws=400):
    """Per point: the former rule's z (half-width of the bootstrap interval / 1.96 as standard
    error) against the normal z with the model's spread, both at 5 %, on t10' of the broken (no
    family noise: the bias is the skewed sample's)."""
    from millsim.analysis.tavares_verification import interval_p_value

    mats = load_materials(truncation="single_particle")
    for name in ("copper_ore", "limestone", "granulite"):
        m = mats[name]
        share = tp.absorbed_share(m)
        Ek = 0.5 * tp.stressing_median(m, DIAMETER, share)
        mean = tp.t10_expected(m, DIAMETER, Ek, share)
        E = T.sample_fracture_energy(m, DIAMETER, (np.arange(200_000) + 0.5) / 200_000)
        spread = T.t10_prime(m, Ek * share, E[E <= Ek * share]).std()
        boot, normal = [], []
        for _ in range(draws):
            E = T.sample_fracture_energy(m, DIAMETER, rng.random(100))
            t = T.t10_prime(m, Ek * share, E[E <= Ek * share])
            if t.size < 2:
                continue
            ci = stats.bootstrap((t,), np.mean, n_resamples=999, method="percentile",
                                 rng=rng).confidence_interval
            boot.append(interval_p_value(t.mean(), ci.low, ci.high, mean) < 0.05)
            normal.append(2 * stats.norm.sf(abs(t.mean() - mean) / (spread / np.sqrt(t.size)))
                          < 0.05)
        print(f"{name}: rejected at 5 %: bootstrap z {np.mean(boot):.3f}, "
              f"normal z with the model's spread {np.mean(normal):.3f} ({len(boot)} draws)")


if __name__ == "__main__":
    main()
