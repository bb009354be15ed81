"""The channels a gust estimate is computed from (the full module comes with the estimator)."""

GUST_SENSORS = (
    "vt_fps",
    "alpha_rad",
    "beta_rad",
    "phi_rad",
    "theta_rad",
    "psi_rad",
    "v_north_fps",
    "v_east_fps",
    "v_down_fps",
)

__all__ = ["GUST_SENSORS"]
