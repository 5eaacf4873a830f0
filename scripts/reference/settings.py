"""The identification settings: the calibration file's `[identification]` table when one is
given, else the bank's (src/model/calibration/defaults.rs for the keys left out)."""

# src/model/calibration/defaults.rs: keys an identification table leaves out take these.
DEFAULT_IDENTIFICATION = {
    "phi": 0.95,
    "pips_per_series": 30,
    "pip_distance": "vertical",
    "alpha_fraction": 0.01,
    "monte_carlo_samples": 20_000,
    "random_subsets": 2000,
    "seed": 1,
    "bank_resolution": 0.5,
    "envelope_windows_per_sensor": 3,
    "envelope_half_width_samples": 2,
    "urgent_l0_mm": 40.0,
    "inspect_l0_mm": 25.0,
    "uncertainty": [
        {"group": "model", "name": "train system", "kind": "relative", "min": -0.15, "max": 0.05},
        {"group": "model", "name": "finite element model", "kind": "relative", "min": -0.08, "max": 0.05},
        {"group": "model", "name": "mesh refinement", "kind": "relative", "min": -0.03, "max": 0.03},
        {"group": "model", "name": "additional", "kind": "relative", "min": -0.01, "max": 0.01},
        {"group": "model", "name": "track calibration", "kind": "relative", "min": -0.05, "max": 0.05},
        {"group": "measurement", "name": "sensor accuracy", "kind": "relative", "min": -0.05, "max": 0.05},
        {"group": "measurement", "name": "environment noise", "kind": "absolute_kn", "min": -1.0, "max": 1.0},
        {"group": "measurement", "name": "sensor resolution", "kind": "absolute_kn", "min": -0.05, "max": 0.05},
        {"group": "measurement", "name": "additional", "kind": "relative", "min": -0.02, "max": 0.02},
    ],
}


def load_settings(meta, calibration_path):
    """Identification settings: the calibration file's when given, else the bank's; keys left
    out take the defaults."""
    settings = dict(DEFAULT_IDENTIFICATION)
    if calibration_path is not None:
        import tomllib

        with open(calibration_path, "rb") as f:
            stored = tomllib.load(f).get("identification", {})
    else:
        stored = meta["calibration"].get("identification", {})
    settings.update({k: v for k, v in stored.items() if k in DEFAULT_IDENTIFICATION})
    return settings
