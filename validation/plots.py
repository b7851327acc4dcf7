"""Telemetry figures of a closed-loop run, like the paper's (its control-input and state figures):
written as PNG from a run's telemetry (validation.observers.Telemetry)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless
import matplotlib.pyplot as plt
import numpy as np

MODE_COLOURS = {"I": "#d9ead3", "II": "#fff2cc", "III": "#f4cccc", "braking": "#eeeeee"}


def mode_bands(t: np.ndarray, modes: np.ndarray, t_end: float) -> list[tuple[float, float, str]]:
    """(start, end, mode) of each run of equal modes over the samples t [s] (one mode a sample)."""
    if len(modes) != len(t):
        raise ValueError(f"{len(modes)} modes for {len(t)} samples; allowed: one mode a sample")
    bands, start = [], 0
    for k in range(1, len(modes) + 1):
        if k == len(modes) or modes[k] != modes[start]:
            bands.append((float(t[start]), float(t[k]) if k < len(t) else t_end, str(modes[start])))
            start = k
    return bands


def write(telemetry: dict[str, np.ndarray], names: dict[str, list[str]], folder: Path) -> list[Path]:
    """Figures: control inputs (thrust, joint torques), states (position, attitude, joint angles),
    distances (hull, the closest other arm link and the tip to the wall) and the contact force.
    `telemetry` holds arrays over the physics pieces: t, u (pieces, nu), h (pieces, ns), hull_distance,
    link_distance, tip_distance, tip_force, mode (the mode of the step each piece belongs to)."""
    folder.mkdir(parents=True, exist_ok=True)
    t, u, h = telemetry["t"], telemetry["u"], telemetry["h"]
    t_end = float(t[-1]) if len(t) else 0.0
    bands = mode_bands(t, telemetry["mode"], t_end)
    nt, n = len(names["thrusters"]), len(names["joints"])
    figures = {
        "control_inputs.png": [("thrust [N]", u[:, :nt], names["thrusters"]),
                               ("joint torque [N m]", u[:, nt:], names["joints"])],
        "states.png": [("position [m]", h[:, :3], ["x", "y", "z"]),
                       ("attitude [deg]", np.degrees(h[:, 3:6]), ["roll", "pitch", "yaw"]),
                       ("joint angle [rad]", h[:, 6:6 + n], names["joints"]),
                       ("body velocity [m/s]", h[:, 6 + n:9 + n], ["u", "v", "w"])],
        "contact.png": [("distance to the wall [m]", np.column_stack([telemetry["hull_distance"],
                                                                     telemetry["link_distance"],
                                                                     telemetry["tip_distance"]]),
                         ["hull", "other arm links (closest)", "tip"]),
                        ("tip contact force [N]", telemetry["tip_force"][:, None], ["peak normal force"])],
    }
    written = []
    for filename, panels in figures.items():
        fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.2 * len(panels)), sharex=True)
        for ax, (label, data, legend) in zip(np.atleast_1d(axes), panels, strict=True):
            for start, end, mode in bands:
                ax.axvspan(start, end, color=MODE_COLOURS.get(mode, "white"), lw=0)
            lines = ax.step(t, data, where="post")
            ax.set_ylabel(label)
            ax.legend(lines, legend, fontsize=6, ncol=4, loc="upper right")
            ax.grid(alpha=0.3)
        np.atleast_1d(axes)[-1].set_xlabel("time [s] (background: mode I green, II yellow, III red)")
        fig.tight_layout()
        fig.savefig(folder / filename, dpi=110)
        plt.close(fig)
        written.append(folder / filename)
    return written
