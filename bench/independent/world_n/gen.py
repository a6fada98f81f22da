#!/usr/bin/env python3
"""World N, "nuisance-swept": World D's rover with random nuisance structure (Python 3 stdlib only).

Every dataset (controls, the 8 catalogued effects and 5 out-of-catalogue causes) draws nuisance
structure from 13 dimensions (README.md): terrain slip track, yaw-rate-dependent angular slip,
speed-loop lag, gyro scale/bias, regeneration limit, per-side and low-duty driver efficiency,
battery, payload offset, a smaller tyre, direction-dependent gearbox friction, an erroneous
rover.toml and the sample rate. The nuisance is present in calibration and test runs alike.

    python3 gen.py --seed S|A-B --out DIR [--count-per-class K] [--workers 2]
    python3 gen.py --nuisance '{"slip_track": {"ratio": 0.9}}' --out DIR [--seed S]

The draws (world structure, effect strength) and the rover, commands and World D's helper
functions are imported from ../world_d/gen.py; the time stepping is World N's own because every
nuisance acts inside it. Each effect / out-of-catalogue dataset D also gets its twin in D/twin/
(same seed, nuisance and noise streams, the effect or cause off).
"""
import argparse
import importlib.util
import json
import math
import multiprocessing
import os
import random
import sys
import time
from collections import deque

_HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location(
    "world_d_gen", os.path.join(_HERE, "..", "world_d", "gen.py"))
wd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(wd)

DT = wd.DT                      # physics step (50 Hz); the written sample rate is a nuisance
G_ACC = wd.G_ACC
CATALOGUE = wd.CLASSES[1:]
OUTSIDE = ["battery-sag", "low-duty", "small-tyre", "gearbox", "payload"]
CLASSES = ["control"] + CATALOGUE + ["outside-" + c for c in OUTSIDE]
DIMS = ["slip_track", "slip_yaw", "loop_lag", "gyro", "regen_limit", "eta_asym", "eta_low_duty",
        "battery", "payload", "wheel_radius", "gearbox", "toml_error", "sample_rate"]
RATES = [100, 200, 500, 1000, 2000]          # with the sample_rate dimension on (else 50 Hz)
RATE_W = [0.35, 0.25, 0.2, 0.12, 0.08]
# Where an out-of-catalogue cause acts: "test" = the test runs only, "all" = every run.
OUTSIDE_WHERE = {"battery-sag": "test", "low-duty": "all", "small-tyre": "all",
                 "gearbox": "all", "payload": "test"}
# The nuisance dimension an out-of-catalogue cause is a strong version of (kept off beside it).
OUTSIDE_DIM = {"battery-sag": "battery", "low-duty": "eta_low_duty", "small-tyre": "wheel_radius",
               "gearbox": "gearbox", "payload": "payload"}
U = random.Random.uniform


# ----------------------------------------------------------------------------------------- draws
def draw_dim(rng, dim, rover, s):
    """Values of one nuisance dimension (ranges: README.md)."""
    husky = rover == "husky"
    if dim == "slip_track":
        return dict(ratio=U(rng, 0.85, 1.15))
    if dim == "slip_yaw":
        return dict(k_per_rad_s=U(rng, 0.03, 0.12))
    if dim == "loop_lag":
        lag = U(rng, 0.05, 0.3)
        f = rng.choice([0.0, 1.0, U(rng, 0.2, 0.8)])
        return dict(dead_s=lag * f, extra_tau_s=lag * (1.0 - f))
    if dim == "gyro":
        return dict(scale=1.0 + U(rng, -0.03, 0.03), bias_rad_s=U(rng, -0.003, 0.003),
                    drift_rad_s2=U(rng, -2e-5, 2e-5))
    if dim == "regen_limit":
        return dict(limit_w=U(rng, 2.0, 15.0) if husky else U(rng, 10.0, 60.0))
    if dim == "eta_asym":
        return dict(asym=rng.choice([-1, 1]) * U(rng, 0.02, 0.06))
    if dim == "eta_low_duty":
        return dict(drop=U(rng, 0.05, 0.15), duty0=0.15)
    if dim == "battery":
        return dict(R_int=U(rng, 0.06, 0.15) if husky else U(rng, 0.03, 0.08),
                    sag_v=U(rng, 0.3, 1.5))
    if dim == "payload":
        return dict(lr=rng.choice([-1, 1]) * U(rng, 0.05, 0.15),
                    fb=rng.choice([-1, 1]) * U(rng, 0.05, 0.2))
    if dim == "wheel_radius":
        return dict(side=rng.choice([0, 1]), shrink=U(rng, 0.04, 0.08))
    if dim == "gearbox":
        return dict(side=rng.choice([0, 1]), direction=rng.choice([1, -1]),
                    frac_of_G=U(rng, 0.05, 0.15))
    if dim == "toml_error":
        which = rng.sample(["track_width_m", "mass_kg", "slip_track_m"], rng.choice([1, 1, 2, 3]))
        return {k: 1.0 + rng.choice([-1, 1]) * U(rng, 0.02, 0.05) for k in sorted(which)}
    if dim == "sample_rate":
        return dict(hz=rng.choices(RATES, RATE_W)[0])
    raise ValueError(dim)


def draw_cause(rng, cause, rover, s):
    """An out-of-catalogue cause, beyond its nuisance dimension's range."""
    husky = rover == "husky"
    if cause == "battery-sag":
        # a nearly flat battery in the test runs: the bus falls so far (and sags so much more
        # under load) that the drivers' top speed drops below the fastest commanded wheel speed
        return dict(v_full_over_vmax=U(rng, 0.72, 0.9), R_int_factor=U(rng, 2.5, 4.0))
    if cause == "low-duty":
        return dict(drop=U(rng, 0.35, 0.6), duty0=0.25)
    if cause == "small-tyre":
        return dict(side=rng.choice([0, 1]), shrink=U(rng, 0.12, 0.2))
    if cause == "gearbox":
        return dict(side=rng.choice([0, 1]), direction=rng.choice([1, -1]),
                    frac_of_G=U(rng, 0.5, 1.0))
    if cause == "payload":
        return dict(lr=rng.choice([-1, 1]) * U(rng, 0.3, 0.45), fb=0.0)
    raise ValueError(cause)


def choose_dims(rng, n):
    """Which dimensions are on for the dataset numbered n: a third one dimension alone (cycling
    through them), a third 2-4 dimensions, a sixth none, a sixth many (7-13)."""
    mode = n % 6
    if mode in (0, 1):
        return "single", [DIMS[(n // 3) % len(DIMS)]]
    if mode in (2, 3):
        return "few", sorted(rng.sample(DIMS, rng.randint(2, 4)), key=DIMS.index)
    if mode == 4:
        return "none", []
    return "many", sorted(rng.sample(DIMS, rng.randint(7, len(DIMS))), key=DIMS.index)


def rounded(x):
    """For truth.json: floats to 6 significant digits."""
    if isinstance(x, float):
        return float(f"{x:.6g}")
    if isinstance(x, dict):
        return {k: rounded(v) for k, v in x.items()}
    if isinstance(x, list):
        return [rounded(v) for v in x]
    return x


# ----------------------------------------------------------------------------------------- world
class World:
    """World D's structure and effect plus nuisance `nz` (dim -> values) and an out-of-catalogue
    cause. `on` switches the effect or cause (False = the twin)."""

    def __init__(self, key, s, cls, e, nz, cause, on):
        self.key, self.s, self.cls, self.e, self.nz, self.on = key, s, cls, e, nz, on
        self.cause_name = cls[len("outside-"):] if cls.startswith("outside-") else None
        self.cause = cause
        self.rv = wd.ROVERS[s["rover"]]                 # the truth the physics uses
        self.r_prime = self.rv["slip_track_m"] / 2.0    # the controller's B_s (firmware)
        self.dT = [0.0, 0.0]
        self.v_max_cmd = 2.0 * s["v_c"]                 # fastest commanded wheel speed
        self.v_rated = self.v_max_cmd * s["v_rated_ratio"]

    # which pieces act in this run
    def effect(self, name, test):
        if not self.on or self.cls != name:
            return False
        return True if name in ("current-offset", "motor-heating") else test

    def cause_on(self, name, test):
        if not self.on or self.cause_name != name:
            return False
        return test if OUTSIDE_WHERE[name] == "test" else True

    def params(self, test):
        """Per-run physical parameters after nuisance and cause."""
        s, nz, rv = self.s, self.nz, self.rv
        p = dict(bs=rv["slip_track_m"], k_yaw=0.0, dead=0.0, tau=s["tau_w"], regen=s["regen"],
                 regen_limit=None, eta=[s["eta"], s["eta"]], low_drop=0.0, duty0=0.15,
                 R_int=s["R_int"], V_oc=s["V_oc"], lr=0.0, fb=0.0, rho=[1.0, 1.0],
                 gb=None, gscale=1.0, gbias=0.0, gdrift=0.0)
        if "slip_track" in nz:
            p["bs"] *= nz["slip_track"]["ratio"]
        if self.effect("slip-track", test):
            p["bs"] *= self.e["ratio"]       # the test patch relative to the nuisance terrain
        if "slip_yaw" in nz:
            p["k_yaw"] = nz["slip_yaw"]["k_per_rad_s"]
        if "loop_lag" in nz:
            p["dead"] = nz["loop_lag"]["dead_s"]
            p["tau"] += nz["loop_lag"]["extra_tau_s"]
        if "gyro" in nz:
            g = nz["gyro"]
            p["gscale"], p["gbias"], p["gdrift"] = g["scale"], g["bias_rad_s"], g["drift_rad_s2"]
        if "regen_limit" in nz:
            p["regen"], p["regen_limit"] = True, nz["regen_limit"]["limit_w"]
        if "eta_asym" in nz:
            a = nz["eta_asym"]["asym"]
            p["eta"] = [min(0.97, s["eta"] * (1.0 + a)), min(0.97, s["eta"] * (1.0 - a))]
        for src, where in ((nz.get("eta_low_duty"), True), (self.cause, self.cause_on("low-duty", test))):
            if src is not None and where and "drop" in src:
                p["low_drop"], p["duty0"] = src["drop"], src["duty0"]
        if "battery" in nz:
            p["R_int"] = nz["battery"]["R_int"]
            if test:
                p["V_oc"] -= nz["battery"]["sag_v"]
        if self.cause_on("battery-sag", test):
            p["R_int"] *= self.cause["R_int_factor"]
            # top speed v_rated * V_bus / V_oc,nominal falls to this fraction of the fastest command
            p["V_oc"] = s["V_oc"] * self.cause["v_full_over_vmax"] / s["v_rated_ratio"]
        for src, where in ((nz.get("payload"), True), (self.cause, self.cause_on("payload", test))):
            if src is not None and where and "lr" in src:
                p["lr"], p["fb"] = src["lr"], src["fb"]
        for src, where in ((nz.get("wheel_radius"), True), (self.cause, self.cause_on("small-tyre", test))):
            if src is not None and where and "shrink" in src:
                p["rho"] = [1.0, 1.0]
                p["rho"][src["side"]] = 1.0 - src["shrink"]
        for src, where in ((nz.get("gearbox"), True), (self.cause, self.cause_on("gearbox", test))):
            if src is not None and where and "frac_of_G" in src:
                p["gb"] = (src["side"], src["direction"], src["frac_of_G"] * s["G"])
        return p

    # ------------------------------------------------------------------------- effect forces
    def inner_drag(self, F, cmd, V, vg, lat, t_in, T0):
        e = self.e
        for k in (0, 1):
            if cmd[k] * vg[k] < 0.0 and abs(cmd[k]) > 1e-9:
                shape = abs(vg[k]) / math.hypot(vg[k], lat)          # sin(beta - 90 deg), Eq 5.1
                grow = 1.0 - math.exp(-t_in / e["tau_pile"])
                F[k] += e["k"] * (T0 + self.s["G"]) * shape * grow * math.tanh(V[k] / 0.01)

    def braked_inner(self, F, V, vg, lat, t_in):
        k_in = 0 if self.s["direction"] > 0 else 1
        k_out = 1 - k_in
        if abs(V[k_out]) > 1e-3:
            Fb = self.e["k"] * self.s["mu"] * self.rv["mass_kg"] * G_ACC / 2.0 * (1.0 - math.exp(-t_in / 0.3))
            F[k_out] += Fb * math.hypot(vg[k_in], lat) / abs(V[k_out]) * math.copysign(1.0, V[k_out])

    def bulldozing(self, F, cmd, V, vg, lat, sink, pile):
        """Sinkage and sand pile of each wheel (Eq 5.25-5.37, GRC-1), World D's construction."""
        e, r_w = self.e, self.rv["wheel_radius_m"]
        P_as = 0.0
        for k in (0, 1):
            v_act = math.hypot(vg[k], lat)
            sinb = lat / v_act if v_act > 1e-6 else 0.0
            d_ss = e["d0"] * (1.0 + e["a"] * sinb * (1.5 if cmd[k] * vg[k] < 0.0 else 1.0))
            sink[k] = e["d0"] if sink[k] is None else sink[k]
            sink[k] += (d_ss - sink[k]) * DT / e["tau_sink"]
            d_avg = (1.0 + wd.SINK_LAMBDA) * sink[k] / 2.0
            w_g = 2.0 * math.sqrt(d_avg * (2.0 * r_w - d_avg))
            pile[k] = min(pile[k] + lat * DT, w_g ** 2 / (2.0 * d_avg / math.tan(wd.SOIL_PHI)))
            F_sb = w_g * sinb * wd.SOIL_RHO * G_ACC * d_avg / 2.0 * \
                (d_avg / math.tan(wd.X_C) + 2.0 * pile[k]) * math.tan(wd.X_C + wd.SOIL_PHI)
            P_as += 2.0 * F_sb * v_act * e["k"]
        vs = abs(V[0]) + abs(V[1])
        if vs > 1e-3:
            for k in (0, 1):
                F[k] += P_as / vs * math.tanh(V[k] / 0.01)

    # ------------------------------------------------------------------------------- one run
    def run(self, name, test):
        """Simulates one run at the physics rate. Returns (rows, segs, seg_of_row): rows hold the
        sensor values before sample noise (t, V_l, I_l, V_r, I_r, cmd_l, cmd_r, yaw, pitch)."""
        s, rv, e = self.s, self.rv, self.e
        p = self.params(test)
        rng_run = random.Random(f"{self.key}:order:{name}")
        turns = list(wd.TEST_SET if test else wd.CAL_SET)
        rng_run.shuffle(turns)
        gaps = [U(rng_run, 2.5, 3.5)] + [U(rng_run, 1.5, 2.2) for _ in turns]
        psi_up = U(rng_run, -math.pi, math.pi)
        V0 = p["V_oc"] + U(rng_run, -0.3, 0.3)
        b_run = p["gbias"] * U(rng_run, 0.5, 1.5)         # gyro bias differs run to run

        B, L, m = rv["track_width_m"], rv["length_m"], rv["mass_kg"]
        bs_t = p["bs"]
        fbf = math.hypot(L * (1.0 - p["fb"] ** 2), bs_t - B) / math.hypot(L, bs_t - B)
        T0 = wd.couple_force(rv, bs_t, s["mu"]) * fbf
        load = [1.0 - p["lr"], 1.0 + p["lr"]]
        heat = self.effect("motor-heating", test)
        heat_C, heat_R = (e["C_th"], e["R_th"]) if heat else (s["C_th"], s["R_th"])
        offset = e["offset"] if self.effect("current-offset", test) else [0.0, 0.0]
        slope = self.effect("slope", test)
        phi = e["Phi"] if slope else 1.0
        x_side = (-B / 2.0, B / 2.0)
        n_dead = int(round(p["dead"] / DT))
        buf = deque([(0.0, 0.0)] * n_dead)
        kloop = 1.0 - math.exp(-DT / p["tau"])

        rows, segs, seg_of = [], [], []
        t, yaw = 0.0, 0.0
        V, dT, I_prev, ar = [0.0, 0.0], self.dT, [0.0, 0.0], 0.0
        Vb, gyro = V0, 0.0
        plan = []
        for i, r in enumerate(turns):
            plan += [("gap", None, gaps[i]), ("move", r, None)]
        plan.append(("gap", None, gaps[-1]))
        for seg_i, (kind, r_mult, dur) in enumerate(plan):
            nzr = random.Random(f"{self.key}:noise:{name}:{seg_i}")
            rep_mu = 1.0 + nzr.gauss(0.0, s["sigma_rep"])
            rep_G = 1.0 + nzr.gauss(0.0, s["sigma_rep"])
            if kind == "move":
                cmd = wd.side_commands(s["v_c"], r_mult, self.r_prime, s["direction"])
                target = math.radians(s["turn_deg"]) if r_mult is not None else None
                t_max = 60.0 if target is not None else s["straight_s"]
                start = len(rows)
                gyro0 = gyro
            else:
                cmd, target, t_max = (0.0, 0.0), None, dur
            sink, pile = [None, None], [0.0, 0.0]
            t_seg = 0.0
            while t_seg < t_max - 1e-9:
                # the speed loop: dead time, then a first-order lag; the driver cannot exceed
                # the speed its bus voltage allows (v_full)
                buf.append(cmd)
                c_eff = buf.popleft()
                v_full = self.v_rated * Vb / s["V_oc"]
                a = [0.0, 0.0]
                for k in (0, 1):
                    nv = V[k] + (c_eff[k] - V[k]) * kloop
                    nv = max(-v_full, min(v_full, nv))
                    a[k] = (nv - V[k]) / DT * p["rho"][k]
                    V[k] = nv
                vg_wheel = [V[0] * p["rho"][0], V[1] * p["rho"][1]]   # smaller tyre: slower ground
                w_kin = (vg_wheel[1] - vg_wheel[0]) / bs_t
                slip = s["slip0"] + p["k_yaw"] * abs(w_kin) if abs(w_kin) > 1e-6 else 0.0
                if self.effect("angular-slip", test) and kind == "move" and r_mult is not None:
                    z = (r_mult - 1.0) / e["width"]
                    slip += e["A"] * math.exp(-z * z)
                w = w_kin * (1.0 - slip)
                v_y = 0.5 * (vg_wheel[0] + vg_wheel[1])
                yaw += w * DT
                gyro = p["gscale"] * yaw + b_run * t + 0.5 * p["gdrift"] * t * t
                ar = 0.97 * ar + math.sqrt(1 - 0.97 ** 2) * nzr.gauss(0.0, 1.0)
                pitch = self.pitch_deg(ar, yaw, psi_up, slope)
                sin_p = math.sin(math.radians(pitch))
                mu_f = rep_mu * (1.0 + 0.01 * nzr.gauss(0.0, 1.0))
                T = T0 * mu_f * math.tanh(abs(w_kin) / s["w0"]) * (1 if w_kin >= 0 else -1)
                lat = abs(w) * L / 2.0
                vg = [v_y + w * x_side[k] for k in (0, 1)]
                F = [0.0, 0.0]
                for k in (0, 1):
                    sgn = math.tanh(V[k] / 0.01)
                    F[k] = (T if k == 1 else -T) * load[k] + s["G"] * rep_G * load[k] * sgn \
                        + 0.55 * m * a[k] + 0.5 * phi * m * G_ACC * sin_p
                if p["gb"] is not None:
                    side, direc, f_gb = p["gb"]
                    if V[side] * direc > 0.0:
                        F[side] += f_gb * math.tanh(V[side] / 0.01)
                if kind == "move":
                    if self.effect("inner-drag", test):
                        self.inner_drag(F, cmd, V, vg, lat, t_seg, T0)
                    if self.effect("braked-inner", test) and r_mult == 1.0:
                        self.braked_inner(F, V, vg, lat, t_seg)
                    if self.effect("sinkage-bulldozing", test) and abs(w) > 1e-4:
                        self.bulldozing(F, cmd, V, vg, lat, sink, pile)
                P_el = [self.side_power(p, k, F[k], V[k], vg_wheel[k], v_full, dT, heat_C, heat_R)
                        for k in (0, 1)]
                Vb, Vs, I_prev = self.bus(p, V0 - 0.0004 * t, P_el, I_prev)
                rows.append((t, Vs[0], s["gain"][0] * I_prev[0] + offset[0], Vs[1],
                             s["gain"][1] * I_prev[1] + offset[1], cmd[0], cmd[1], gyro, pitch))
                seg_of.append(seg_i)
                t += DT
                t_seg += DT
                if kind == "move" and target is not None:
                    # the controller turns until its own heading (the gyro) has turned far enough
                    if abs(gyro - gyro0) >= target:
                        break
            if kind == "move":
                segs.append(dict(r_mult=r_mult, start=start, end=len(rows)))
        # the windings cool during the rest before the next run
        self.dT = [x * math.exp(-PAUSE_S / (heat_R * heat_C)) for x in dT]
        return rows, segs, seg_of

    def pitch_deg(self, rough, yaw, psi_up, slope):
        """IMU pitch: terrain roughness, plus on an incline the slope seen along the heading."""
        out = self.s["pitch_rough_deg"] * rough
        if slope:
            tan_s = math.tan(math.radians(self.e["theta_deg"]))
            out += math.degrees(math.atan(tan_s * math.cos(yaw - psi_up)))
        return out

    def side_power(self, p, k, F, V, vg, v_full, dT, heat_C, heat_R):
        """Electrical power of side k (Eq 1.17-1.19) with the driver's efficiency at its duty,
        and its regeneration rule; updates the winding temperature dT[k]."""
        s = self.s
        I_m = F * p["rho"][k] / (s["k_F"] * (1.0 - 0.0012 * dT[k]))  # torque F r_k; magnets -0.12 %/K
        P_cu = I_m * I_m * (s["R_w"] * (1.0 + 0.00393 * dT[k]))        # copper +0.393 %/K
        P_m = F * vg
        duty = min(1.0, abs(V) / max(v_full, 1e-6))
        eta = p["eta"][k] * (1.0 - p["low_drop"] * math.exp(-duty / p["duty0"]))
        if P_m >= 0.0:
            q = P_m / eta + P_cu
        else:
            q = eta * P_m + P_cu
            if not p["regen"]:
                q = max(q, 0.0)
            elif p["regen_limit"] is not None:
                q = max(q, -p["regen_limit"])
        dT[k] = min(150.0, dT[k] + (P_cu - dT[k] / heat_R) / heat_C * DT)
        return q

    def bus(self, p, Voc, P_el, I_prev):
        """Battery and wiring: I = P / V by two fixed-point steps from the last currents. A weak
        battery does not collapse below 60 % of its open-circuit voltage (the drivers'
        undervoltage cut-out), which keeps the fixed point bounded."""
        s = self.s
        for _ in range(2):
            Vb = max(0.6 * Voc, Voc - p["R_int"] * (I_prev[0] + I_prev[1]))
            Vs = [Vb - s["R_wire"][k] * I_prev[k] for k in (0, 1)]
            I_prev = [P_el[k] / Vs[k] + s["I_q"][k] for k in (0, 1)]
        return Vb, Vs, I_prev


PAUSE_S = wd.PAUSE_S


def write_run(path, rows, seg_of, key, name, hz):
    """Writes one CSV at `hz`: the physics rows linearly interpolated (commands held), each
    written sample with its own sensor noise (current 30 mA, bus 1.5 mV, yaw 0.3 mrad, pitch
    0.02 deg; INA226 quantisation). The noise streams restart per segment (twin-aligned)."""
    m = hz // 50
    out = ["t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,"
           "cmd_left_mps,cmd_right_mps,yaw_rad,pitch_deg\n"]
    g = None
    cur = -1
    n = len(rows)
    for i in range(n):
        if seg_of[i] != cur:
            cur = seg_of[i]
            g = random.Random(f"{key}:sample:{name}:{cur}").gauss
        r0 = rows[i]
        r1 = rows[i + 1] if i + 1 < n else r0
        for j in range(m):
            f = j / m
            vals = [r0[c] + (r1[c] - r0[c]) * f for c in (1, 2, 3, 4, 7, 8)]
            out.append("%.4f,%.5f,%.4f,%.5f,%.4f,%.6f,%.6f,%.5f,%.3f\n" % (
                r0[0] + f * DT,
                round((vals[0] + g(0.0, 0.0015)) / 0.00125) * 0.00125,
                round((vals[1] + g(0.0, 0.03)) / 0.0005) * 0.0005,
                round((vals[2] + g(0.0, 0.0015)) / 0.00125) * 0.00125,
                round((vals[3] + g(0.0, 0.03)) / 0.0005) * 0.0005,
                r0[5], r0[6], vals[4] + g(0.0, 0.0003), vals[5] + g(0.0, 0.02)))
    with open(path, "w") as fh:
        fh.write("".join(out))


def write_rover(path, rv, nz):
    err = nz.get("toml_error", {})
    with open(path, "w") as f:
        for name in ("track_width_m", "length_m", "wheel_radius_m", "mass_kg", "slip_track_m"):
            v = rv[name] * err.get(name, 1.0)
            f.write(f"{name} = {round(v, 4) if name in err else v}\n")


# ------------------------------------------------------------------------------------ datasets
def build(key, cls, n_index, nz_override=None):
    """Draws one dataset's world: structure (World D's draw), effect, nuisance, cause."""
    srng = random.Random(key + ":structure")
    rover = "argo" if srng.random() < 0.25 else "husky"
    s = wd.draw_structure(srng, rover)
    s["v_rated_ratio"] = U(srng, 1.25, 1.45)     # drivers' top speed over the fastest command
    eff_cls = cls if cls in CATALOGUE else "control"
    e = wd.draw_effect(random.Random(key + ":effect"), eff_cls, rover)
    nrng = random.Random(key + ":nuisance")
    cause_dim = OUTSIDE_DIM.get(cls[len("outside-"):]) if cls.startswith("outside-") else None
    if nz_override is not None:
        mode, nz = "given", {}
        for dim in DIMS:                          # given values over a draw's defaults
            if dim in nz_override and dim != cause_dim:
                vals = draw_dim(random.Random(key + ":" + dim), dim, rover, s)
                vals.update(nz_override[dim] or {})
                nz[dim] = vals
    else:
        mode, dims = choose_dims(nrng, n_index)
        nz = {d: draw_dim(nrng, d, rover, s) for d in dims if d != cause_dim}
    cause = draw_cause(random.Random(key + ":cause"), cls[len("outside-"):], rover, s) \
        if cls.startswith("outside-") else None
    return s, e, nz, cause, mode


def simulate_dataset(d, key, cls, s, e, nz, cause, on):
    """Simulates and writes the five runs into d; returns the test runs for the twin check."""
    w = World(key, s, cls, e, nz, cause, on)
    hz = nz.get("sample_rate", {}).get("hz", 50)
    os.makedirs(d, exist_ok=True)
    write_rover(os.path.join(d, "rover.toml"), w.rv, nz)
    runs = []
    for name, test in (("cal_0", False), ("cal_1", False), ("run_0", True), ("run_1", True), ("run_2", True)):
        rows, segs, seg_of = w.run(name, test)
        write_run(os.path.join(d, name + ".csv"), rows, seg_of, key, name, hz)
        if test:
            runs.append((rows, segs))
    return runs, hz


def make_one(job):
    """job = (seed, cls, k, out, nuisance or None[, twin]): writes one dataset (and its twin
    unless twin is False); returns (name, truth)."""
    seed, cls, k, out, nz_override = job[:5]
    with_twin = job[5] if len(job) > 5 else True
    key = f"wn:{seed}:{cls}:{k}"
    n_index = seed * 7 + k * len(CLASSES) + CLASSES.index(cls)
    s, e, nz, cause, mode = build(key, cls, n_index, nz_override)
    name = f"{cls}-{seed}-{k}"
    d = os.path.join(out, name)
    runs, hz = simulate_dataset(d, key, cls, s, e, nz, cause, True)
    truth = dict(cls=cls, effect="none" if cls == "control" else
                 cls if cls in CATALOGUE else "outside:" + cls[len("outside-"):],
                 regime=wd.REGIME.get(cls))
    if cls != "control" and with_twin:
        twin_runs, _ = simulate_dataset(os.path.join(d, "twin"), key, cls, s, e, nz, cause, False)
        vis_cls = cls if cls in CATALOGUE else "power"
        rms, sigma, largest, peak = wd.visibility(vis_cls, runs, twin_runs)
        thr = max(1.5, 3.0 * sigma)
        if cls == "sinkage-bulldozing":
            truth["regime"] = wd.regime_of(largest, wd.ROVERS[s["rover"]], s)
        truth.update(visible=rms > thr, twin_rms_w=round(rms, 3), repeat_sigma_w=round(sigma, 3),
                     threshold_w=round(thr, 3), visible_local=peak > thr,
                     largest_manoeuvre_diff_w=round(peak, 3), largest_at_r_over_r_prime=largest)
    if cause is not None:
        truth["cause"] = dict(name=cls[len("outside-"):], where=OUTSIDE_WHERE[cls[len("outside-"):]],
                              params=rounded(cause))
    truth.update(rover=s["rover"], sample_rate_hz=hz, nuisance_mode=mode,
                 nuisance_dims=[dd for dd in DIMS if dd in nz], nuisance=rounded(nz),
                 params=rounded(e), structure=rounded(s))
    with open(os.path.join(d, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1, sort_keys=True)
    return name, truth


def generate(seeds, out, count, workers=2, classes=None):
    os.makedirs(out, exist_ok=True)
    jobs = [(seed, cls, k, out, None) for seed in seeds for k in range(count)
            for cls in (classes or CLASSES)]
    if workers > 1:
        with multiprocessing.Pool(workers) as pool:
            return pool.map(make_one, jobs, chunksize=1)
    return [make_one(j) for j in jobs]


def make_control(nuisance, out, seed=0, cls="control", k=0, twin=True):
    """One dataset of class `cls` (default a control) with the given nuisance values
    ({dim: {value: ...}}; a dim given as {} or null takes its seed's draw). Returns (dir, truth)."""
    name, truth = make_one((seed, cls, k, out, nuisance, twin))
    return os.path.join(out, name), truth


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", default=None, help="a seed, or a range A-B (inclusive)")
    ap.add_argument("--out", required=True, help="output directory (outside the repository)")
    ap.add_argument("--count-per-class", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--nuisance", help="JSON {dim: {values}}: one control with this nuisance")
    ap.add_argument("--class", dest="cls", default="control", help="with --nuisance: the class")
    ap.add_argument("--k", type=int, default=0, help="with --nuisance: the dataset index (world draw)")
    a = ap.parse_args()
    t0 = time.time()
    if a.nuisance is not None:
        d, truth = make_control(json.loads(a.nuisance), a.out, int(a.seed or 0), a.cls, a.k)
        print(d)
        print(json.dumps(truth["nuisance"], sort_keys=True))
        return
    if a.seed is None:
        ap.error("--seed is required (or --nuisance)")
    lo, _, hi = a.seed.partition("-")
    made = generate(range(int(lo), int(hi or lo) + 1), a.out, a.count_per_class, a.workers)
    for name, tr in made:
        vis = "" if "visible" not in tr else f" visible={tr['visible']!s:5} rms={tr['twin_rms_w']:7.2f} W"
        print(f"{name:34} {tr['rover']:5} {tr['sample_rate_hz']:5} Hz {tr['nuisance_mode']:6} "
              f"{','.join(tr['nuisance_dims']) or '-':40.40}{vis}")
    print(f"{len(made)} datasets in {a.out} ({time.time() - t0:.1f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
