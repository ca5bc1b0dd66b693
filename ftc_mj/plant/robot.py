"""The MuJoCo truth plant: the differential-drive robot stepped at the physics rate with tyre-fault schedules.

Usage pattern (the sim loop)::

    plant = Plant(cfg.plant, cfg.robot, cfg.faults)   # builds and compiles the model once
    plant.reset()
    while plant.time < duration:
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
printed nor appended to ``MUJOCO_LOG.TXT`` in the working directory (:mod:`~ftc_mj.plant.physics_warnings`): the
flags carry them. A model MuJoCo cannot allocate or simulate at all (``mujoco.FatalError``, e.g. tens of
thousands of bodies) is a :class:`~ftc_mj.errors.BadInput` naming ``plant.model_file``.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..errors import BadInput
from ..model.kinematics import inverse_rates
from .base import PlantClock
from .builder import build_model
from .faults.records import wheel_schedules
from .faults.tyre import EPS_T, RadiusSchedule, wheel_index
from .layout import model_layout
from .mujoco_truth import attitude, axle_motion, chassis_rotation, domain_flags, world_rate, wrap_angle
from .physics_warnings import BAD_STATE_WARNINGS, silence_mujoco_warnings
from .settings import FaultSettings, PlantSettings, RobotSettings, plant_geometry
from .truth import NAN, PHYSICS_WARNING, UNSTABLE, Truth


class Plant(PlantClock):
    """The MuJoCo truth plant of one run.

    Args:
        plant: the plant settings (model file, variant, timestep, geometry overrides, initial pose, flag
            limits; :class:`~ftc_mj.plant.settings.PlantSettings`).
        robot: the robot settings (nominal radius and half track, m; rate limit, rad/s).
        faults: the fault settings: the radius schedules of the right and left wheel, and the plant faults
            acting through their effects (:mod:`~ftc_mj.plant.faults.servo`: gain, torque limit and hinge
            damping changed in place).
    """

    kind = "mujoco"

    def __init__(self, plant: PlantSettings, robot: RobotSettings, faults: FaultSettings) -> None:
        self.settings = plant
        silence_mujoco_warnings()
        self.model: mujoco.MjModel = build_model(plant, robot)
        self.nominal_radius, self.half_track = (float(v) for v in plant_geometry(plant, robot))
        self.omega_max: float = float(robot.omega_max)
        try:
            self._setup(plant, faults)
        except mujoco.FatalError as err:  # the model is too large for MuJoCo's arena or stack
            why = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            raise BadInput(f"plant.model_file: {plant.model_file}: MuJoCo cannot simulate it: {why}") from None

    def _setup(self, pc: PlantSettings, faults: FaultSettings) -> None:
        """Allocate the data, look up every named element, reset (the part of construction that runs MuJoCo)."""
        self.data: mujoco.MjData = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)  # mj_setConst overwrites the qpos of the data it is given
        m = self.model
        self.dt: float = float(m.opt.timestep)
        self.variant: str = pc.variant
        self.reseat_default: bool = bool(pc.reseat_hub)
        self.initial_pose: tuple[float, float, float] = tuple(float(v) for v in pc.initial_pose)  # type: ignore[assignment]
        self.schedules: tuple[RadiusSchedule, RadiusSchedule] = wheel_schedules(faults, self.nominal_radius)
        self.layout = L = model_layout(m, self.variant)
        self._g_sphere, self._g_visual, self._g_spoke = L.sphere_geoms, L.visual_geoms, L.spoke_geoms
        self._root_q, self._slide_q, self._act = L.root_q, L.slide_q, L.actuators
        self._setup_faults(faults)
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
        """Back to t = 0: initial pose from ``plant.initial_pose``, wheels resting on the floor, at rest, radii
        from the fault schedules at t = 0, commands zero, flags cleared."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        m.qpos_spring[:] = self._qpos_spring0
        self._radius = [self.nominal_radius, self.nominal_radius]
        for i in (0, 1):
            self._write_radius(i, self.nominal_radius)
        self._refresh_bounds()
        x0, y0, psi0 = self.initial_pose
        q = self._root_q
        d.qpos[q : q + 7] = (x0, y0, self.nominal_radius, math.cos(psi0 / 2), 0.0, 0.0, math.sin(psi0 / 2))
        if self._slide_q is not None:
            d.qpos[self._slide_q[0]] = 0.0
            d.qpos[self._slide_q[1]] = 0.0
        self._k = 0
        self._frozen = False
        self._sticky = 0
        self._psi = psi0
        self._psi_raw = wrap_angle(psi0)
        for i, s in enumerate(self.schedules):
            r = s.value(EPS_T)
            if r != self._radius[i]:
                self.set_wheel_radius("right" if i == 0 else "left", r, reseat=True)
        d.ctrl[:] = 0.0
        d.time = 0.0
        self._restart_faults()
        mujoco.mj_forward(m, d)
        self._save_good()

    def set_motion(self, v: float, yaw_rate: float) -> None:
        """Start in steady rolling motion (call right after :meth:`reset`): chassis forward speed ``v`` (m/s) and
        ``yaw_rate`` (rad/s), wheels spinning at the rolling rates and the servos commanded to them, so that a run can
        begin on the path at the reference speed instead of from rest (the torque limit allows only about 4 m/s^2)."""
        m, d = self.model, self.data
        q, dv = self._root_q, self.layout.root_v
        qw, qz = d.qpos[q + 3], d.qpos[q + 6]
        psi = 2.0 * math.atan2(qz, qw)
        d.qvel[dv : dv + 3] = (v * math.cos(psi), v * math.sin(psi), 0.0)
        d.qvel[dv + 3 : dv + 6] = (0.0, 0.0, yaw_rate)  # free joint: angular velocity in the body frame (level)
        wR, wL = inverse_rates(v, yaw_rate, self._radius[0], self._radius[1], self.half_track)
        d.qvel[self.layout.hinge_v[0]] = wR
        d.qvel[self.layout.hinge_v[1]] = wL
        self.set_command(wR, wL)
        mujoco.mj_forward(m, d)
        self._save_good()

    @property
    def frozen(self) -> bool:
        """True after a non-finite state: the physics no longer advances."""
        return self._frozen

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
        """Size the collision sphere, the drawn tyre and the spoke of wheel ``i`` for radius ``r`` (m)."""
        gs = self._geom_size
        gs[self._g_sphere[i], 0] = r
        gs[self._g_visual[i], 0] = r * self.layout.visual_ratio
        if self._g_spoke[i] >= 0:
            gs[self._g_spoke[i], 0] = r * self.layout.spoke_ratio

    def _refresh_bounds(self) -> None:
        """Recompute the geoms' bounding volumes (rbound, aabb, BVH) for the current sizes. ``mj_setConst``
        overwrites the qpos of the data it is given, so it runs on a scratch ``MjData``."""
        mujoco.mj_setConst(self.model, self._scratch)
        self._bound_radius = [self._radius[0], self._radius[1]]

    def set_wheel_radius(self, wheel: str, r: float, reseat: bool = True) -> None:
        """Set a wheel's radius (m) now, in place (no recompile): the collision sphere and the drawn tyre.

        Refreshes the derived bounds with ``mj_setConst`` on a scratch ``MjData`` whenever the radius grows beyond
        the one the bounds were computed for (else the broadphase would cull real contacts). Shrinking keeps the
        larger bounds, which is conservative (the broadphase only tests a few more pairs) and keeps a per-step ramp
        cheap; :meth:`reset` and any growth recompute them.

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
        self._write_radius(i, r)
        self._radius[i] = r
        if r > self._bound_radius[i]:
            self._refresh_bounds()
        if reseat and self._slide_q is not None and dr != 0.0:
            a = self._slide_q[i]
            lo, hi = self.layout.slide_range[i]  # type: ignore[index]
            qpos = self._qpos
            q = qpos[a] + dr
            qpos[a] = lo if q < lo else (hi if q > hi else q)
            # Self-levelling: the strut's spring reference follows the hub, so the down-force is unchanged.
            self._qpos_spring[a] += dr

    # ------------------------------------------------------------------ stepping
    def _advance(self, n: int) -> None:
        """Advance ``n`` physics steps with the held commands, applying the fault schedules at every physics
        step in which they change (a single ``mj_step(m, d, n)`` call when they do not)."""
        if n <= 0:
            return
        m, d = self.model, self.data
        k0 = self._k
        dt = self.dt
        if self._frozen:
            self._k = k0 + n
            d.time = self._k * dt
            return
        t0 = k0 * dt + EPS_T
        t1 = (k0 + n - 1) * dt + EPS_T
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
                t = (k0 + j) * dt + EPS_T
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
        if finite and not (warn[BAD_STATE_WARNINGS[0]] or warn[BAD_STATE_WARNINGS[1]]
                           or warn[BAD_STATE_WARNINGS[2]]):
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
        the last physics step. Call it at the estimator rate, not per physics step. The heading is unwrapped between
        calls, so call it at least once per half turn of the robot (any sim loop does).
        """
        if not self._sticky & PHYSICS_WARNING and any(self._warning_number.tolist()):
            self._sticky |= PHYSICS_WARNING
        L = self.layout
        qp = self._qpos.tolist()
        qv = self._qvel.tolist()
        a, b = L.root_q, L.root_v
        pos = qp[a : a + 3]
        rot = chassis_rotation(qp[a + 3 : a + 7])
        roll, pitch, psi_raw = attitude(rot)
        self._psi += wrap_angle(psi_raw - self._psi_raw)
        self._psi_raw = psi_raw
        psi = self._psi
        spin = world_rate(rot, qv[b + 3 : b + 6])
        if L.slide_q is not None:
            qs = (qp[L.slide_q[0]], qp[L.slide_q[1]])
            qsd = (qv[L.slide_v[0]], qv[L.slide_v[1]])  # type: ignore[index]
        else:
            qs = qsd = (0.0, 0.0)
        omegas = (qv[L.hinge_v[0]], qv[L.hinge_v[1]])
        x, y, v, slips = axle_motion(rot, pos, qv[b : b + 3], spin, psi, L.hub_y, qs, qsd, omegas, self._radius)
        flags, contact_R, contact_L = self._flags(roll, pitch, rot[8], slips)
        if not all(math.isfinite(q) for q in (x, y, psi, v, spin[2], roll, pitch, pos[2])):
            flags |= NAN
        return Truth(
            t=self._k * self.dt,
            x=x,
            y=y,
            psi=psi,
            v=v,
            yaw_rate=spin[2],
            omega_R=omegas[0],
            omega_L=omegas[1],
            R_R=self._radius[0],
            R_L=self._radius[1],
            roll=roll,
            pitch=pitch,
            z_chassis=pos[2],
            slip_R=slips[0],
            slip_L=slips[1],
            contact_R=contact_R,
            contact_L=contact_L,
            flags=flags,
        )

    def _flags(self, roll: float, pitch: float, upright: float, slips: list[float]) -> tuple[int, bool, bool]:
        """The flags of this state (sticky ones included) and whether each tyre touched the floor in the last
        physics step (``roll``, ``pitch`` in rad; ``upright``: r22 of the chassis rotation; slip speeds in m/s)."""
        d = self.data
        geoms = set(d.contact.geom.ravel().tolist()) if d.ncon else set()
        contact_R = self._g_sphere[0] in geoms
        contact_L = self._g_sphere[1] in geoms
        flags = self._sticky | domain_flags(contact_R, contact_L, bool(geoms & self.layout.scrape_geoms), roll, pitch,
                                            upright, slips, self._tilt_limit, self._tipped_limit, self._slip_limit)
        return flags, contact_R, contact_L

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
