"""The truth record a plant reports, and the flags for leaving the kinematic model's domain."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

# Bit flags of Truth.flags: "the plant left the kinematic model's domain". They describe the state at
# the time of the Truth, except NAN, UNSTABLE and PHYSICS_WARNING, which are sticky (once raised they stay raised).
LIFTOFF = 1 << 0
"""A drive tyre has no contact with the floor."""
SCRAPE = 1 << 1
"""The chassis body touches the floor."""
LARGE_ROLL = 1 << 2
"""|roll| or |pitch| above ``plant.tilt_limit_deg``."""
TIPPED = 1 << 3
"""|roll| or |pitch| above ``plant.tipped_limit_deg`` (or the chassis is upside down): the robot fell over."""
SLIP = 1 << 4
"""|longitudinal slip speed| of a tyre above ``plant.slip_limit``."""
PHYSICS_WARNING = 1 << 5
"""MuJoCo raised a warning (bad qacc/qpos/qvel, contact or constraint buffer full, bad inertia). Sticky."""
NAN = 1 << 6
"""The physics state became non-finite; the plant froze at the last finite state. Sticky."""
UNSTABLE = 1 << 7
"""MuJoCo's own check found NaN, Inf or a huge value (above 1e10) in the positions, velocities or
accelerations (its "simulation is unstable" warning, after which it resets the state); the plant froze at
the last good state. Sticky. A run with UNSTABLE or NAN has the status ``unstable``."""

FLAG_NAMES: dict[int, str] = {
    LIFTOFF: "LIFTOFF",
    SCRAPE: "SCRAPE",
    LARGE_ROLL: "LARGE_ROLL",
    TIPPED: "TIPPED",
    SLIP: "SLIP",
    PHYSICS_WARNING: "PHYSICS_WARNING",
    NAN: "NAN",
    UNSTABLE: "UNSTABLE",
}


def flag_names(flags: int) -> list[str]:
    """Names of the bits set in ``flags``."""
    return [name for bit, name in FLAG_NAMES.items() if flags & bit]


def describe_flags(flags: int) -> str:
    """Comma-separated names of the bits in a :attr:`Truth.flags` value (``"none"`` for 0)."""
    return ", ".join(flag_names(flags)) or "none"


@dataclass(slots=True)
class Truth:
    """Ground truth of the plant at time ``t``. SI units, radians.

    Attributes:
        t: simulation time (s).
        x, y: axle-midpoint position (m): the midpoint of the two wheel centres, projected on the floor.
        psi: heading (rad) of the chassis x axis in the floor plane, unwrapped (continuous across ±pi).
        v: forward speed (m/s) of the axle midpoint along the heading.
        yaw_rate: world-z angular velocity of the chassis (rad/s).
        omega_R, omega_L: measured wheel joint rates (rad/s) relative to the hub (what an encoder reads).
        R_R, R_L: true wheel radii (m).
        roll, pitch: chassis roll and pitch (rad), ZYX Euler angles (pitch > 0 = nose down).
        z_chassis: height (m) of the chassis frame origin (the nominal axle midpoint) above the floor.
        slip_R, slip_L: longitudinal slip speed (m/s) of each tyre: rim speed minus ground speed, i.e. minus the
            velocity of the sphere's lowest point along the heading. Positive = spinning faster than the ground
            moves (driving slip), negative = skidding (braking slip); 0 = rolling without slip.
        contact_R, contact_L: the tyre had a floor contact in the last physics step.
        flags: bitmask of LIFTOFF, SCRAPE, LARGE_ROLL, TIPPED, SLIP, PHYSICS_WARNING, NAN, UNSTABLE.
    """

    t: float
    x: float
    y: float
    psi: float
    v: float
    yaw_rate: float
    omega_R: float
    omega_L: float
    R_R: float
    R_L: float
    roll: float
    pitch: float
    z_chassis: float
    slip_R: float
    slip_L: float
    contact_R: bool
    contact_L: bool
    flags: int

    def as_dict(self) -> dict[str, Any]:
        """Field name -> value."""
        return asdict(self)
