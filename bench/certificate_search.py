"""The certificate's optional line-search SQP screen (controller.feasibility), off and on, side by
side in one run: the switching NMPC in closed loop on the Kane model (validation.kane_closed_loop)
in its two thruster-failure approaches, where the screens before it fail at most Mode I steps.

Per run: the mode sequence, the closest hull distance, Mode I's whole-step time (median, p95), and
how the certificate decided (its evidence, with the median time of each kind of decision).

`python bench/certificate_search.py` writes bench/results/certificate_search.md.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from controller.switching import Mode, SwitchingSettings
from validation.closed_loop import SEARCH_ITERATIONS as SEARCH
from validation.kane_closed_loop import SCENARIOS, run

OUT = Path(__file__).resolve().parent / "results" / "certificate_search.md"


def main() -> None:
    rows = ["| scenario | screen | modes | min hull distance [m] | Mode I step median / p95 [ms] | "
            "certificate decisions: count, median [ms] |", "|---|---|---|---|---|---|"]
    for name in ("kane-thrusters-dead", "kane-thrusters-dead-current"):
        for search in (0, SEARCH):
            r = run(SCENARIOS[name], SwitchingSettings(certificate_search=search))
            steps = [1e3 * i.solve_time for i in r.infos if i.mode is Mode.I]
            by: dict[str, list[float]] = defaultdict(list)
            for i in r.infos:
                if i.certificate is not None:
                    by[f"{i.certificate.method.value} ({i.certificate.verdict.value})"].append(
                        1e3 * i.certificate.solve_time)
            decided = "; ".join(f"{k}: {len(v)}, {np.median(v):.0f}" for k, v in sorted(by.items()))
            rows.append(f"| {name} | {'off' if search == 0 else f'{search} iterations'} | "
                        f"{' > '.join(m.value for m in r.modes)} | {r.hull_distance.min():.3f} | "
                        f"{np.median(steps):.0f} / {np.percentile(steps, 95):.0f} | {decided} |")
            print(rows[-1], flush=True)
    text = ("# The certificate's line-search screen, off and on (Kane-model closed loop)\n\n"
            "`python bench/certificate_search.py`\n\n" + "\n".join(rows) + "\n")
    OUT.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
