"""Does the shifted warm start's last interval (the last state repeated, so the accelerations are 0
and the dynamics rows are off by the forces) cost Mode III its iterations? Each recorded warm
problem solved from its recorded guess and from the same guess with the last node simulated (the
model's RK4 under the last input and force, the joints put back on the plane, as the controller's
re-simulation does).

  PYTHONPATH=. python experiments/mode3_attitude_probe/tail.py   # writes tail.md and tail.manifest.json
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr, wilcoxon

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
from mode3_solvers import load_problems

from controller.mode3 import ModeIIIOCP, ModeIIISettings

HERE = Path(__file__).parent


def main() -> None:
    data, cold, model, scene = load_problems()
    o = ModeIIIOCP(model, scene.planes, int(data["contact"][0]), ModeIIISettings())
    g = o.warm_solver.get_function("nlp_g")
    nc = o.ns + o.nv + 3 + o.n_clear
    rows, viol = [], []
    for i in np.flatnonzero(~cold):
        o.limit_inputs(data["lo"][i], data["hi"][i])
        duals, current = (data["lam_g"][i], data["lam_x"][i]), data["current"][i]
        a = o.solve(data["h0"][i], data["guess"][i], current, duals)
        P = o.parameters(data["h0"][i], current)
        gv = np.asarray(g(np.clip(data["guess"][i], *o.bounds()), P)).ravel()
        v = np.maximum(o.lbg - gv, 0) + np.maximum(gv - o.ubg, 0)
        viol.append((v.max(), v[o.ns:o.ns + nc].max(), v[o.ns + nc:].max()))
        hs, us, Fs = o.unpack(data["guess"][i])
        x = model.held_steps(hs[-2], us[-1], o.settings.dt, 4, Fw=np.concatenate([Fs[-1], np.zeros(3)]), Rw=o.Rw,
                             vc=current)
        x[6:6 + model.n_joints] = o.onto_plane(x)
        hs = hs.copy()
        hs[-1] = x
        b = o.solve(data["h0"][i], o.pack(hs, us, Fs), current, duals)
        rows.append((a.iterations, b.iterations, a.status.usable, b.status.usable, a.cost, b.cost))
    r, v = np.array(rows, float), np.array(viol)
    rho = spearmanr(v[:, 0], r[:, 0])
    head = (f"The recorded warm starts' worst constraint violation: median {np.median(v[:, 0]):.3g} (first interval "
            f"{np.median(v[:, 1]):.3g}, later ones {np.median(v[:, 2]):.3g}); Spearman with the iterations "
            f"{rho.statistic:.2f} (p = {rho.pvalue:.1g}).\n\n")
    text = (f"{len(r)} warm problems: iterations median (p90) {np.median(r[:, 0]):.0f} "
            f"({np.percentile(r[:, 0], 90):.0f}) from the recorded guess, {np.median(r[:, 1]):.0f} "
            f"({np.percentile(r[:, 1], 90):.0f}) with the simulated "
            f"last node; fewer in {int(np.sum(r[:, 1] < r[:, 0]))}, more in {int(np.sum(r[:, 1] > r[:, 0]))}, "
            f"Wilcoxon p = {wilcoxon(r[:, 0], r[:, 1]).pvalue:.2g}; unusable {int(np.sum(r[:, 2] == 0))} / "
            f"{int(np.sum(r[:, 3] == 0))}; cost < 0.9x / > 1.1x the recorded guess's: "
            f"{int(np.sum(r[:, 5] < 0.9 * r[:, 4]))} / {int(np.sum(r[:, 5] > 1.1 * r[:, 4]))}\n")
    text = head + text
    (HERE / "tail.md").write_text(text)
    print(text)


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(HERE / "tail.manifest.json", {"problems": "out/mode3_problems.npz"}):
        main()
