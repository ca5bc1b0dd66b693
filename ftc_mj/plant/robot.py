"""The MuJoCo truth plant: the differential-drive robot stepped at the physics rate with tyre-fault schedules.

Usage pattern (the sim loop)::

    plant = Plant(cfg)              # builds and compiles the model once
    plant.reset()
    while plant.time < cfg.duration:
        plant.set_command(wR, wL)   # rad/s, clipped to +-omega_max, held (zero-order hold)
        plant.advance(10)           # 10 physics steps (10 ms at 1 kHz), fault schedules applied per step
        tr = plant.truth()          # Truth at plant.time (computed only here, not per step)

Speed: when no fault schedule changes within an ``advance`` window, all steps run in one ``mj_step(m, d, n)``
call (no per-step Python). :meth:`Plant.truth` reads the pose and velocities straight from ``qpos``/``qvel`` (exact
at the current time, no ``mj_forward`` needed); contacts are those MuJoCo used in the last physics step.

Failure handling: an unstable simulation never raises. When the state becomes non-finite, or MuJoCo's own
check reports NaN, Inf or huge values in ``qpos``/``qvel``/``qacc`` (it then silently resets the state to the
model's initial one), the plant restores the last good state (the end of the previous successful ``advance``
call), freezes (time still advances, the physics does not) and reports ``UNSTABLE | PHYSICS_WARNING`` (plus
``NAN`` for a non-finite state) in every later :class:`~ftc_mj.plant.truth.Truth`. Other MuJoCo warnings raise
the sticky ``PHYSICS_WARNING`` flag (checked in :meth:`Plant.truth`). MuJoCo's warning texts are neither
printed nor appended to ``MUJOCO_LOG.TXT`` in the working directory (:func:`silence_mujoco_warnings`): the
flags carry them. A model MuJoCo cannot allocate or simulate at all (``mujoco.FatalError``, e.g. tens of
thousands of bodies) is a :class:`~ftc_mj.errors.BadInput` naming ``plant.model_file``.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..config import RunConfig
from ..errors import BadInput
from ..model.kinematics import inverse_rates
from .builder import build_model
from .faults import RadiusSchedule
from .truth import LARGE_ROLL, LIFTOFF, NAN, PHYSICS_WARNING, SCRAPE, SLIP, TIPPED, UNSTABLE, Truth, flag_names

_EPS_T = 1e-9  # s; schedule lookups happen at k*dt + _EPS_T so that breakpoints on step times are hit robustly

_WHEEL_INDEX = {"right": 0, "r": 0, "R": 0, "left": 1, "l": 1, "L": 1}


def wheel_index(wheel: str) -> int:
    """0 for ``"right"``/``"R"``, 1 for ``"left"``/``"L"``; ``ValueError`` otherwise."""
    try:
        return _WHEEL_INDEX[wheel]
    except KeyError:
        raise ValueError(f"wheel must be 'right' or 'left' (or 'R'/'L'), got {wheel!r}") from None


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


_BAD_STATE_WARNINGS = tuple(int(w) for w in (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                                             mujoco.mjtWarning.mjWARN_BADQACC))
"""MuJoCo's "simulation is unstable" warnings (NaN, Inf or > 1e10 in qpos, qvel, qacc)."""


def _drop_warning(message: str) -> None:
    """MuJoCo warning handler: the plant reads the warning counters of ``MjData`` instead."""


def silence_mujoco_warnings() -> None:
    """Route MuJoCo's warning texts to a handler that drops them, instead of MuJoCo's default, which prints
    them and appends them to ``MUJOCO_LOG.TXT`` in the current working directory. Process-wide and
    idempotent; the counters in ``MjData.warning`` (and so the plant's flags) are unaffected."""
    if mujoco.get_mju_user_warning() is not _drop_warning:
        mujoco.set_mju_user_warning(_drop_warning)


class Plant:
    """The MuJoCo truth plant of one run.

    Args:
        cfg: the run config; uses ``cfg.plant`` (model, variant, timestep, limits), ``cfg.robot`` (nominal radius,
            half track, rate limit) and ``cfg.faults`` (radius schedules of the right and left wheel).
    """

    kind = "mujoco"

    def __init__(self, cfg: RunConfig) -> None:
        self.cfg = cfg
        pc = cfg.plant
        silence_mujoco_warnings()
        self.model: mujoco.MjModel = build_model(pc, cfg.robot)
        try:
            self._setup(cfg)
        except mujoco.FatalError as err:  # the model is too large for MuJoCo's arena or stack
            why = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            raise BadInput(f"plant.model_file: {pc.model_file}: MuJoCo cannot simulate it: {why}") from None

    def _setup(self, cfg: RunConfig) -> None:
        """Allocate the data, look up every named element, reset (the part of construction that runs MuJoCo)."""
        pc = cfg.plant
        self.data: mujoco.MjData = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)  # mj_setConst overwrites the qpos of the data it is given
        m = self.model
        self.dt: float = float(m.opt.timestep)
        self.nominal_radius: float = float(cfg.plant_wheel_radius)
        self.half_track: float = float(cfg.plant_half_track)
        self.omega_max: float = float(cfg.robot.omega_max)
        self.variant: str = pc.variant
        self.reseat_default: bool = bool(pc.reseat_hub)
        self.schedules: tuple[RadiusSchedule, RadiusSchedule] = (
            RadiusSchedule(cfg.faults.right, self.nominal_radius, "faults.right"),
            RadiusSchedule(cfg.faults.left, self.nominal_radius, "faults.left"),
        )
        # ---- ids and addresses (by name: the MJCF contract)
        self._g_sphere = (m.geom("wheel_right").id, m.geom("wheel_left").id)
        self._g_visual = (m.geom("wheel_right_visual").id, m.geom("wheel_left_visual").id)
        spokes = []
        for side in ("right", "left"):
            try:
                spokes.append(m.geom(f"wheel_{side}_spoke").id)
            except KeyError:
                spokes.append(-1)
        self._g_spoke = tuple(spokes)
        self._visual_ratio = float(m.geom_size[self._g_visual[0], 0] / m.geom_size[self._g_sphere[0], 0])
        self._spoke_ratio = (
            float(m.geom_size[self._g_spoke[0], 0] / m.geom_size[self._g_sphere[0], 0]) if spokes[0] >= 0 else 0.0
        )
        root = m.joint("root")
        self._root_q = int(root.qposadr[0])
        self._root_v = int(root.dofadr[0])
        self._hinge_v = tuple(int(m.joint(f"hinge_{s}").dofadr[0]) for s in ("right", "left"))
        self._slide_q: tuple[int, int] | None
        self._slide_v: tuple[int, int] | None
        self._slide_range: tuple[tuple[float, float], tuple[float, float]] | None
        if self.variant == "suspended":
            js = (m.joint("slide_right"), m.joint("slide_left"))
            self._slide_q = (int(js[0].qposadr[0]), int(js[1].qposadr[0]))
            self._slide_v = (int(js[0].dofadr[0]), int(js[1].dofadr[0]))
            self._slide_range = tuple((float(j.range[0]), float(j.range[1])) for j in js)  # type: ignore[assignment]
        else:
            self._slide_q = self._slide_v = self._slide_range = None
        self._hub_y = (float(m.body("hub_right").pos[1]), float(m.body("hub_left").pos[1]))
        self._act = (m.actuator("act_right").id, m.actuator("act_left").id)
        floor = m.geom("floor").id
        chassis_body = m.body("chassis").id
        excluded = {floor, m.geom("caster").id, *self._g_sphere}
        # Scrape = a colliding geom of the chassis or hubs (not the caster, not the tyres) touches the floor.
        self._scrape_geoms = frozenset(
            g
            for g in range(m.ngeom)
            if g not in excluded
            and (m.geom_contype[g] or m.geom_conaffinity[g])
            and m.geom_bodyid[g] != 0
            and m.geom_bodyid[g] in {chassis_body, m.body("hub_right").id, m.body("hub_left").id}
        )
        self._tilt_limit = math.radians(pc.tilt_limit_deg)
        self._tipped_limit = math.radians(pc.tipped_limit_deg)
        self._slip_limit = float(pc.slip_limit)
        self._qpos_spring0 = m.qpos_spring.copy()
        # numpy views of the model/data arrays used every step (a property access builds a new view each time)
        d = self.data
        self._geom_size = m.geom_size
        self._qpos_spring = m.qpos_spring
        self._qpos = d.qpos
        self._qvel = d.qvel
        self._warning_number = d.warning.number
        self._qpos_good = np.empty(m.nq)
        self._qvel_good = np.empty(m.nv)
        self._act_good = np.empty(m.na)
        self.reset()
        # trial steps (0.05 s, the robot settling on its tyres and caster) from the initial state on the
        # scratch data: a model whose arena cannot hold a step's contacts and constraints fails here, as
        # bad input, instead of in the middle of a run
        np.copyto(self._scratch.qpos, self.data.qpos)
        mujoco.mj_step(m, self._scratch, max(1, round(0.05 / self.dt)))
        mujoco.mj_resetData(m, self._scratch)  # the scratch data is back to what mj_setConst expects

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to t = 0: initial pose from ``cfg.plant.initial_pose``, wheels resting on the floor, at rest, radii
        from the fault schedules at t = 0, commands zero, flags cleared."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        m.qpos_spring[:] = self._qpos_spring0
        self._radius = [self.nominal_radius, self.nominal_radius]
        for i in (0, 1):
            self._write_radius(i, self.nominal_radius)
        self._refresh_bounds()
        x0, y0, psi0 = (float(v) for v in self.cfg.plant.initial_pose)
        q = self._root_q
        d.qpos[q : q + 7] = (x0, y0, self.nominal_radius, math.cos(psi0 / 2), 0.0, 0.0, math.sin(psi0 / 2))
        if self._slide_q is not None:
            d.qpos[self._slide_q[0]] = 0.0
            d.qpos[self._slide_q[1]] = 0.0
        self._k = 0
        self._frozen = False
        self._sticky = 0
        self._psi = psi0
        self._psi_raw = _wrap(psi0)
        for i, s in enumerate(self.schedules):
            r = s.value(_EPS_T)
            if r != self._radius[i]:
                self.set_wheel_radius("right" if i == 0 else "left", r, reseat=True)
        d.ctrl[:] = 0.0
        d.time = 0.0
        mujoco.mj_forward(m, d)
        self._save_good()

    def set_motion(self, v: float, yaw_rate: float) -> None:
        """Start in steady rolling motion (call right after :meth:`reset`): chassis forward speed ``v`` (m/s) and
        ``yaw_rate`` (rad/s), wheels spinning at the rolling rates and the servos commanded to them, so that a run can
        begin on the path at the reference speed instead of from rest (the torque limit allows only about 4 m/s^2)."""
        m, d = self.model, self.data
        q, dv = self._root_q, self._root_v
        qw, qz = d.qpos[q + 3], d.qpos[q + 6]
        psi = 2.0 * math.atan2(qz, qw)
        d.qvel[dv : dv + 3] = (v * math.cos(psi), v * math.sin(psi), 0.0)
        d.qvel[dv + 3 : dv + 6] = (0.0, 0.0, yaw_rate)  # free joint: angular velocity in the body frame (level)
        wR, wL = inverse_rates(v, yaw_rate, self._radius[0], self._radius[1], self.half_track)
        d.qvel[self._hinge_v[0]] = wR
        d.qvel[self._hinge_v[1]] = wL
        self.set_command(wR, wL)
        mujoco.mj_forward(m, d)
        self._save_good()

    @property
    def time(self) -> float:
        """Simulation time (s): number of physics steps taken times the timestep."""
        return self._k * self.dt

    @property
    def steps(self) -> int:
        """Physics steps taken since :meth:`reset`."""
        return self._k

    @property
    def frozen(self) -> bool:
        """True after a non-finite state: the physics no longer advances."""
        return self._frozen

    @property
    def radii(self) -> tuple[float, float]:
        """Current true radii ``(R_R, R_L)`` (m)."""
        return self._radius[0], self._radius[1]

    # ------------------------------------------------------------------ inputs
    def set_command(self, omega_R: float, omega_L: float) -> None:
        """Wheel-rate commands (rad/s) to the velocity servos, clipped to ``±omega_max``; held until changed."""
        lim = self.omega_max
        ctrl = self.data.ctrl
        wR, wL = float(omega_R), float(omega_L)
        ctrl[self._act[0]] = 0.0 if wR != wR else (lim if wR > lim else (-lim if wR < -lim else wR))
        ctrl[self._act[1]] = 0.0 if wL != wL else (lim if wL > lim else (-lim if wL < -lim else wL))

    @property
    def command(self) -> tuple[float, float]:
        """The (clipped) commands ``(omega_R, omega_L)`` currently applied (rad/s)."""
        return float(self.data.ctrl[self._act[0]]), float(self.data.ctrl[self._act[1]])

    def _write_radius(self, i: int, r: float) -> None:
        gs = self._geom_size
        gs[self._g_sphere[i], 0] = r
        gs[self._g_visual[i], 0] = r * self._visual_ratio
        if self._g_spoke[i] >= 0:
            gs[self._g_spoke[i], 0] = r * self._spoke_ratio

    def _refresh_bounds(self) -> None:
        """Recompute the geoms' bounding volumes (rbound, aabb, BVH) for the current sizes. ``mj_setConst``
        overwrites the qpos of the data it is given, so it runs on a scratch ``MjData``."""
        mujoco.mj_setConst(self.model, self._scratch)
        self._bound_radius = [self._radius[0], self._radius[1]]

    def set_wheel_radius(self, wheel: str, r: float, reseat: bool = True) -> None:
        """Set a wheel's radius (m) now, in place (no recompile): the collision sphere and the drawn tyre.

        Refreshes the derived bounds with ``mj_setConst`` on a scratch ``MjData`` whenever the radius grows beyond
        the one the bounds were computed for (else the broadphase would cull real contacts). Shrinking keeps the
        larger bounds, which is conservative (the broadphase only tests a few more pairs) and makes a per-step ramp
        cost ~2 µs instead of ~9 µs per step; :meth:`reset` and any growth recompute them.

        With ``reseat`` (suspended variant only) the hub moves along its slide by the radius change and the strut's
        spring reference moves with it (a levelling suspension), so the tyre stays on the floor with the same
        down-force and the chassis stays level, for a step (shrinking or growing) as for a ramp. Without it the strut
        is passive: a shrunken tyre hangs on its spring. Mass and inertia are unchanged (a puncture loses air, not
        rubber).

        Args:
            wheel: ``"right"``/``"R"`` or ``"left"``/``"L"``.
            r: new radius (m), > 0.
            reseat: re-seat the hub (see above).
        """
        i = wheel_index(wheel)
        r = float(r)
        if not (math.isfinite(r) and r > 0):
            raise ValueError(f"wheel radius must be finite and > 0, got {r}")
        self._apply_radius(i, r, reseat)

    def _apply_radius(self, i: int, r: float, reseat: bool) -> None:
        """:meth:`set_wheel_radius` for wheel index ``i`` and a valid radius ``r`` (the per-step path of a ramp)."""
        dr = r - self._radius[i]
        gs = self._geom_size
        gs[self._g_sphere[i], 0] = r
        gs[self._g_visual[i], 0] = r * self._visual_ratio
        if self._g_spoke[i] >= 0:
            gs[self._g_spoke[i], 0] = r * self._spoke_ratio
        self._radius[i] = r
        if r > self._bound_radius[i]:
            self._refresh_bounds()
        if reseat and self._slide_q is not None and dr != 0.0:
            a = self._slide_q[i]
            lo, hi = self._slide_range[i]  # type: ignore[index]
            qpos = self._qpos
            q = qpos[a] + dr
            qpos[a] = lo if q < lo else (hi if q > hi else q)
            # Self-levelling: the strut's spring reference follows the hub, so the down-force is unchanged.
            self._qpos_spring[a] += dr

    # ------------------------------------------------------------------ stepping
    def advance(self, n: int) -> None:
        """Advance ``n`` physics steps (``n * dt`` seconds) with the held commands, applying the fault schedules
        at every physics step in which they change (a single ``mj_step(m, d, n)`` call when they do not)."""
        n = int(n)
        if n <= 0:
            return
        m, d = self.model, self.data
        k0 = self._k
        dt = self.dt
        if self._frozen:
            self._k = k0 + n
            d.time = self._k * dt
            return
        t0 = k0 * dt + _EPS_T
        t1 = (k0 + n - 1) * dt + _EPS_T
        sR, sL = self.schedules
        reseat = self.reseat_default
        # Values at the window start (covers steps exactly at t0 and the end of a ramp).
        for i, s in ((0, sR), (1, sL)):
            if s.active and t0 <= s.end_time + dt:
                r = s.value(t0)
                if r != self._radius[i]:
                    self.set_wheel_radius("right" if i == 0 else "left", r, reseat)
        chR = sR.changing(t0, t1)
        chL = sL.changing(t0, t1)
        if not (chR or chL):
            mujoco.mj_step(m, d, n)
        else:
            radius = self._radius
            apply = self._apply_radius
            step = mujoco.mj_step
            vR, vL = sR.value, sL.value
            for j in range(n):
                t = (k0 + j) * dt + _EPS_T
                if chR:
                    r = vR(t)
                    if r != radius[0]:
                        apply(0, r, reseat)
                if chL:
                    r = vL(t)
                    if r != radius[1]:
                        apply(1, r, reseat)
                step(m, d)
        self._k = k0 + n
        d.time = self._k * dt
        # sum() of a list is NaN if any entry is NaN or +-inf (much cheaper than numpy for these short vectors)
        finite = math.isfinite(sum(self._qvel.tolist())) and math.isfinite(sum(self._qpos.tolist()))
        warn = self._warning_number
        if finite and not (warn[_BAD_STATE_WARNINGS[0]] or warn[_BAD_STATE_WARNINGS[1]]
                           or warn[_BAD_STATE_WARNINGS[2]]):
            self._save_good()
            return
        d.qpos[:] = self._qpos_good
        d.qvel[:] = self._qvel_good
        if m.na:
            d.act[:] = self._act_good
        mujoco.mj_forward(m, d)
        self._frozen = True
        self._sticky |= UNSTABLE | PHYSICS_WARNING | (0 if finite else NAN)

    def _save_good(self) -> None:
        """Remember the current (finite) state, restored if a later advance diverges."""
        d = self.data
        np.copyto(self._qpos_good, d.qpos)
        np.copyto(self._qvel_good, d.qvel)
        if self.model.na:
            np.copyto(self._act_good, d.act)

    # ------------------------------------------------------------------ truth
    def truth(self) -> Truth:
        """The true state at :attr:`time` (see :class:`~ftc_mj.plant.truth.Truth` for definitions).

        Pose and velocities come directly from ``qpos``/``qvel`` (exact at the current time); contacts are those of
        the last physics step. Call at the estimator rate (it costs about 12 µs), not per physics step. The heading is
        unwrapped between calls, so call it at least once per half turn of the robot (any sim loop does).
        """
        d = self.data
        if not self._sticky & PHYSICS_WARNING and any(self._warning_number.tolist()):
            self._sticky |= PHYSICS_WARNING
        qp = self._qpos
        qv = self._qvel
        qp = qp.tolist()
        qv = qv.tolist()
        a = self._root_q
        px, py, pz, w, qx, qy, qz = qp[a : a + 7]
        nq = math.sqrt(w * w + qx * qx + qy * qy + qz * qz) or 1.0
        w, qx, qy, qz = w / nq, qx / nq, qy / nq, qz / nq
        # rotation matrix (world <- chassis)
        r00 = 1 - 2 * (qy * qy + qz * qz)
        r01 = 2 * (qx * qy - w * qz)
        r02 = 2 * (qx * qz + w * qy)
        r10 = 2 * (qx * qy + w * qz)
        r11 = 1 - 2 * (qx * qx + qz * qz)
        r12 = 2 * (qy * qz - w * qx)
        r20 = 2 * (qx * qz - w * qy)
        r21 = 2 * (qy * qz + w * qx)
        r22 = 1 - 2 * (qx * qx + qy * qy)
        roll = math.atan2(r21, r22)
        pitch = math.asin(max(-1.0, min(1.0, -r20)))
        psi_raw = math.atan2(r10, r00)
        self._psi += _wrap(psi_raw - self._psi_raw)
        self._psi_raw = psi_raw
        psi = self._psi
        c, s = math.cos(psi), math.sin(psi)

        b = self._root_v
        vx, vy, vz, lx, ly, lz = qv[b : b + 6]
        # world angular velocity of the chassis
        wx = r00 * lx + r01 * ly + r02 * lz
        wy = r10 * lx + r11 * ly + r12 * lz
        wz = r20 * lx + r21 * ly + r22 * lz

        if self._slide_q is not None:
            qs = (qp[self._slide_q[0]], qp[self._slide_q[1]])
            qsd = (qv[self._slide_v[0]], qv[self._slide_v[1]])  # type: ignore[index]
        else:
            qs = qsd = (0.0, 0.0)
        hubs = []
        slips = []
        omegas = (qv[self._hinge_v[0]], qv[self._hinge_v[1]])
        for i in (0, 1):
            ay, az = self._hub_y[i], qs[i]
            # hub offset in world: R (0, ay, az)
            ox, oy, oz = r01 * ay + r02 * az, r11 * ay + r12 * az, r21 * ay + r22 * az
            hx, hy, hz = px + ox, py + oy, pz + oz
            # hub velocity: v + w x o + R e_z qdot
            hvx = vx + (wy * oz - wz * oy) + r02 * qsd[i]
            hvy = vy + (wz * ox - wx * oz) + r12 * qsd[i]
            hvz = vz + (wx * oy - wy * ox) + r22 * qsd[i]
            # wheel angular velocity: chassis + R e_y * omega
            Wx = wx + r01 * omegas[i]
            Wy = wy + r11 * omegas[i]
            r = self._radius[i]
            # lowest point of the sphere: hub - r e_z; velocity = v_hub + W x (0, 0, -r)
            cvx = hvx - r * Wy
            cvy = hvy + r * Wx
            slips.append(-(cvx * c + cvy * s))
            hubs.append((hx, hy, hz, hvx, hvy, hvz))
        x = 0.5 * (hubs[0][0] + hubs[1][0])
        y = 0.5 * (hubs[0][1] + hubs[1][1])
        v = 0.5 * ((hubs[0][3] + hubs[1][3]) * c + (hubs[0][4] + hubs[1][4]) * s)

        geoms = set(d.contact.geom.ravel().tolist()) if d.ncon else set()
        contact_R = self._g_sphere[0] in geoms
        contact_L = self._g_sphere[1] in geoms
        flags = self._sticky
        if not (contact_R and contact_L):
            flags |= LIFTOFF
        if geoms & self._scrape_geoms:
            flags |= SCRAPE
        tilt = max(abs(roll), abs(pitch))
        if tilt > self._tilt_limit:
            flags |= LARGE_ROLL
        if tilt > self._tipped_limit or r22 < 0.0:
            flags |= TIPPED
        if abs(slips[0]) > self._slip_limit or abs(slips[1]) > self._slip_limit:
            flags |= SLIP
        vals = (x, y, psi, v, wz, roll, pitch, pz)
        if not all(math.isfinite(q) for q in vals):
            flags |= NAN
        return Truth(
            t=self._k * self.dt,
            x=x,
            y=y,
            psi=psi,
            v=v,
            yaw_rate=wz,
            omega_R=omegas[0],
            omega_L=omegas[1],
            R_R=self._radius[0],
            R_L=self._radius[1],
            roll=roll,
            pitch=pitch,
            z_chassis=pz,
            slip_R=slips[0],
            slip_L=slips[1],
            contact_R=contact_R,
            contact_L=contact_L,
            flags=flags,
        )

    @staticmethod
    def describe_flags(flags: int) -> str:
        """Comma-separated names of the bits in a :attr:`Truth.flags` value (``"none"`` for 0)."""
        return ", ".join(flag_names(flags)) or "none"

    def forward(self) -> None:
        """Recompute all derived quantities (``xpos``, contacts, sensors) for the current state: call before
        rendering or reading ``data`` directly (after ``mj_step`` they belong to the start of the last step)."""
        mujoco.mj_forward(self.model, self.data)

    def hub_heights(self) -> tuple[float, float]:
        """Heights (m) of the right and left wheel centres above the floor (from ``xpos`` after kinematics)."""
        mujoco.mj_kinematics(self.model, self.data)
        xp = self.data.xpos
        return (
            float(xp[self.model.geom_bodyid[self._g_sphere[0]], 2]),
            float(xp[self.model.geom_bodyid[self._g_sphere[1]], 2]),
        )
