#!/usr/bin/env python3
"""World D: an independent skid-steer motor-power simulator (Python 3 standard library only).

Written from the thesis text alone ("Power modeling of skid-steer rovers on loose soil",
/work/shared/seeds/000_06e321faa4997e80.txt, equation numbers below refer to it) and the file
layout of /work/shared/foreign-datasets. It does not share code or assumptions with the tool
under test.

    python3 gen.py --seed S --out DIR [--count-per-class K] [--rover husky|argo|mixed]

writes DIR/<class>-<S>-<k>/{rover.toml, cal_0.csv, cal_1.csv, run_0.csv, run_1.csv, run_2.csv,
truth.json} for the control class and the 8 catalogued effects. Every effect dataset is also
simulated as its twin (same structure, same noise draws, effect off) to decide whether the
effect is visible at all (README.md states the rule).
"""
import argparse
import json
import math
import os
import random
import sys
import time

DT = 0.02          # 50 Hz, like the example datasets
G_ACC = 9.81
PAUSE_S = 60.0     # rest between two runs (the winding cools, it is not reset)

# Rovers: thesis Table 3.2 (Husky A200) and Table 3.1 (Argo J5). slip_track_m is the
# controller's slip track B_s; R' = B_s / 2 (Eq 2.5). The Argo's controller uses B_s = B
# (Appendix D).
ROVERS = {
    "husky": dict(track_width_m=0.545, length_m=0.52, wheel_radius_m=0.165, mass_kg=63.0,
                  slip_track_m=1.10),
    "argo": dict(track_width_m=1.14, length_m=0.98, wheel_radius_m=0.30, mass_kg=372.0,
                 slip_track_m=1.14),
}

# GRC-1 simulant, thesis Table 3.3 and Table 5.1 (used by the sinkage-bulldozing effect).
SOIL_RHO = 1788.5                  # dry bulk density [kg/m^3]
SOIL_PHI = math.radians(42.0)      # internal friction angle phi_i
SINK_LAMBDA = 0.7                  # wheel sinkage ratio lambda
X_C = math.radians(45.0) - SOIL_PHI / 2.0   # Bekker's destructive angle, Eq 1.35

CLASSES = ["control", "inner-drag", "sinkage-bulldozing", "angular-slip", "slip-track",
           "braked-inner", "current-offset", "motor-heating", "slope"]
REGIME = {"control": None, "inner-drag": "dragged-inner", "sinkage-bulldozing": None,
          "angular-slip": "at-r-prime", "slip-track": "all", "braked-inner": "at-r-prime",
          "current-offset": "all", "motor-heating": "all", "slope": "all"}

# Turn sets as multiples of R' (None = straight line). Calibration: thesis' reference turns
# (point turn, 2R', 3R', straight). Test: the Husky sandbox set of Sections 4.4 / 5 (R'/3,
# 2R'/3, R', 4R'/3 of Table 5.2) plus 0, 0.8R', 2R' and a straight.
CAL_SET = [0.0, 2.0, 3.0, None]
TEST_SET = [0.0, 1.0 / 3.0, 2.0 / 3.0, 0.8, 1.0, 4.0 / 3.0, 2.0, None]


def side_commands(v_c, r_mult, r_prime, direction):
    """Left/right commanded speeds under the constant total-absolute-velocity constraint
    (Eq 2.6, Appendix A Eq A.13/A.14). direction +1 = left turn (left side inner)."""
    if r_mult is None:
        return v_c, v_c
    R = r_mult * r_prime
    if R < r_prime:
        inner, outer = v_c * (R / r_prime - 1.0), v_c * (1.0 + R / r_prime)
    elif R == r_prime:
        inner, outer = 0.0, 2.0 * v_c
    else:
        inner, outer = v_c * (1.0 - r_prime / R), v_c * (1.0 + r_prime / R)
    return (inner, outer) if direction > 0 else (outer, inner)


def u(rng, a, b):
    return rng.uniform(a, b)


def draw_structure(rng, rover_name):
    """Per-dataset structure, present in controls too (not an effect)."""
    rv = ROVERS[rover_name]
    husky = rover_name == "husky"
    s = dict(rover=rover_name)
    s["direction"] = rng.choice([1, -1])
    s["v_c"] = round(u(rng, 0.2, 0.5), 3)
    s["turn_deg"] = rng.choice([90.0, 180.0])
    s["straight_s"] = round(u(rng, 3.0, 5.0), 2)
    s["slip0"] = u(rng, 0.02, 0.08)             # terrain-wide angular slip (Eq 6.3) on every turn
    # ICR power model, Eq 1.16: skid power = mu |w| sum p_n d_n; rolling/internal G (|V_l|+|V_r|)
    s["mu"] = u(rng, 0.6, 1.0) if husky else u(rng, 0.7, 1.1)
    s["G"] = u(rng, 50.0, 120.0) if husky else u(rng, 180.0, 300.0)
    s["R_T"] = u(rng, 10.0, 25.0)               # radius where the inner side draws power again
    s["eta"] = u(rng, 0.75, 0.92)               # driver/gear efficiency (Eq 1.18/1.19, eta_l, eta_r)
    s["k_F"] = u(rng, 20.0, 35.0) if husky else u(rng, 60.0, 100.0)    # side force per motor amp
    s["R_w"] = u(rng, 0.25, 0.5) if husky else u(rng, 0.05, 0.12)      # winding resistance R_m
    s["C_th"] = u(rng, 800.0, 2000.0)           # winding heat capacity [J/K]: normal, slow heating
    s["R_th"] = u(rng, 2.0, 4.0)                # winding-to-ambient thermal resistance [K/W]
    s["regen"] = rng.random() < 0.5             # does a generating side return current to the bus?
    q = rng.random() < 0.5
    s["I_q"] = [u(rng, 0.02, 0.15) if q else 0.0, u(rng, 0.02, 0.15) if q else 0.0]
    s["gain"] = [1.0 + u(rng, -0.01, 0.01), 1.0 + u(rng, -0.01, 0.01)]   # 5 mOhm shunt, +-1 %
    s["V_oc"] = u(rng, 24.8, 26.2)
    s["R_int"] = u(rng, 0.02, 0.05) if husky else u(rng, 0.01, 0.025)
    s["R_wire"] = [u(rng, 0.004, 0.012), u(rng, 0.004, 0.012)]
    s["tau_w"] = u(rng, 0.05, 0.12)             # wheel speed loop time constant [s]
    s["sigma_rep"] = u(rng, 0.01, 0.03)         # manoeuvre-to-manoeuvre variation (soil, repeats)
    s["sigma_i"] = 0.03                         # current noise per sample [A]
    s["pitch_rough_deg"] = u(rng, 0.05, 0.3)    # terrain roughness seen by the IMU
    # Friction saturation (Eq 1.13, tau = p mu (1 - exp(-j/K))): the tread couple fades when the
    # skid is slow (large R). w0 is chosen so that the inner side's regeneration stops at R_T
    # (thesis Appendix F, Fig 11: ~18 m on concrete at v_c = 0.3 m/s).
    T0 = couple_force(rv, rv["slip_track_m"], s["mu"])
    ratio = s["G"] / T0
    s["w0"] = 0.3 / (s["R_T"] * math.atanh(ratio)) if ratio < 0.98 else 0.01
    return s


def couple_force(rv, bs_terrain, mu):
    """Tread couple T: each side's force +-T so that T (V_o - V_i) equals the ICR model's skid
    power mu |w| sum_n p_n ||a - C_n|| (Eq 1.16) with symmetric ICRs at +-B_s/2 (Eq 2.11, App F
    Eq 20-22): sum_n p_n d_n = m g sqrt(L^2 + (B_s - B)^2) / 2, and V_o - V_i = w B_s (Eq 2.2)."""
    F = 0.5 * mu * rv["mass_kg"] * G_ACC * math.hypot(rv["length_m"], bs_terrain - rv["track_width_m"])
    return F / bs_terrain


def draw_effect(rng, cls, rover_name):
    """Effect strength, drawn per dataset from a plausible range."""
    e = {}
    if cls == "inner-drag":
        e["k"] = u(rng, 0.3, 1.0)          # extra inner torque, thesis 5.2: ~70 % more at 2R'/3
        e["tau_pile"] = u(rng, 0.5, 2.0)   # pile in front of the counter-rotating wheel grows
    elif cls == "sinkage-bulldozing":
        e["k"] = u(rng, 0.5, 2.0)          # scale of the Eq 5.35 force (the thesis' own is small)
        e["d0"] = u(rng, 0.008, 0.015)     # static sinkage d_0 (Table 5.1: 0.01 m)
        e["a"] = u(rng, 1.0, 3.0)          # extra sinkage from lateral skid
        e["tau_sink"] = u(rng, 1.0, 3.0)
    elif cls == "angular-slip":
        e["A"] = u(rng, 0.03, 0.25)        # extra angular slip at R'
        e["width"] = u(rng, 0.3, 0.6)      # in units of R'
    elif cls == "slip-track":
        if rover_name == "argo" or rng.random() < 0.6:   # B_s >= B always (Eq 1.4)
            e["ratio"] = u(rng, 1.1, 1.3)   # thesis Table D.1: sandbox 1.21 m vs internal 1.1 m
        else:
            e["ratio"] = u(rng, 0.7, 0.9)   # firm wet sand (CSA): smaller slip track
    elif cls == "braked-inner":
        e["k"] = u(rng, 0.1, 0.45)          # braked wheel resistance / (mu m g / 2), thesis 6.2
    elif cls == "current-offset":
        e["offset"] = [u(rng, 0.3, 0.8), u(rng, 0.3, 0.8)]
    elif cls == "motor-heating":
        e["C_th"] = u(rng, 6.0, 25.0)      # poorly cooled winding: small heat capacity [J/K]
        e["R_th"] = u(rng, 4.0, 7.0)        # and a poor path to ambient [K/W]
    elif cls == "slope":
        e["theta_deg"] = u(rng, 3.0, 10.0)
        e["Phi"] = u(rng, 0.9, 1.2)         # Phi of Eq 1.16
    return e


class Sim:
    """One world: rover, structure and (maybe) an effect. run() simulates one CSV."""

    def __init__(self, key, s, cls, e, effect_on):
        self.key, self.s, self.cls, self.e, self.on = key, s, cls, e, effect_on
        self.rv = ROVERS[s["rover"]]
        self.r_prime = self.rv["slip_track_m"] / 2.0          # Eq 2.5 with the controller's B_s
        # Winding temperature rise, carried from run to run: the runs are driven in the order
        # cal_0, cal_1, run_0, run_1, run_2 with a PAUSE_S rest between them.
        self.dT = [0.0, 0.0]

    def active(self, name, test):
        if not self.on or self.cls != name:
            return False
        # Sensor and motor effects are properties of the hardware: every run. Terrain effects
        # belong to the test patch: the calibration runs are driven on the reference patch.
        return True if name in ("current-offset", "motor-heating") else test

    def run(self, name, test, drive=None):
        """Simulates one CSV: the turn set (shuffled), or `drive`, a list of manoeuvres
        (r_mult or None for a straight, turn_deg, v_c, straight_s, direction) driven in order
        on the test patch (a scenario file, see drive_scenario)."""
        s, rv, e = self.s, self.rv, self.e
        rng_run = random.Random(f"{self.key}:order:{name}")   # same in the twin
        if drive is None:
            turns = list(TEST_SET if test else CAL_SET)
            rng_run.shuffle(turns)
            drive = [dict(r_mult=r, turn_deg=s["turn_deg"], v_c=s["v_c"],
                          straight_s=s["straight_s"], direction=s["direction"]) for r in turns]
        turns = [m["r_mult"] for m in drive]
        gaps = [u(rng_run, 2.5, 3.5)] + [u(rng_run, 1.5, 2.2) for _ in turns]
        psi_up = u(rng_run, -math.pi, math.pi)
        V0 = s["V_oc"] + u(rng_run, -0.3, 0.3)

        B, L, m = rv["track_width_m"], rv["length_m"], rv["mass_kg"]
        bs_t = rv["slip_track_m"]
        if self.active("slip-track", test):
            bs_t *= e["ratio"]
        T0 = couple_force(rv, bs_t, s["mu"])
        heat = self.active("motor-heating", test)
        heat_C, heat_R = (e["C_th"], e["R_th"]) if heat else (s["C_th"], s["R_th"])
        offset = e["offset"] if self.active("current-offset", test) else [0.0, 0.0]
        slope = self.active("slope", test)
        x_side = (-B / 2.0, B / 2.0)   # lateral position of the left/right wheels (x to the right)

        rows, segs = [], []
        t, yaw = 0.0, 0.0
        V = [0.0, 0.0]                 # actual wheel rim speeds
        dT = self.dT                   # winding temperature rise (carried over)
        I_prev = [0.0, 0.0]
        ar = 0.0                       # AR(1) state of the terrain roughness seen in pitch

        # Timeline: gap, manoeuvre, gap, manoeuvre, ..., gap
        plan = []
        for i, r in enumerate(turns):
            plan.append(("gap", None, gaps[i]))
            plan.append(("move", r, None))
        plan.append(("gap", None, gaps[-1]))

        for seg_i, (kind, r_mult, dur) in enumerate(plan):
            nz = random.Random(f"{self.key}:noise:{name}:{seg_i}")      # same draws in the twin
            rep_mu = 1.0 + nz.gauss(0.0, s["sigma_rep"])
            rep_G = 1.0 + nz.gauss(0.0, s["sigma_rep"])
            if kind == "move":
                man = drive[seg_i // 2]
                cmd = side_commands(man["v_c"], r_mult, self.r_prime, man["direction"])
                yaw0 = yaw
                target = math.radians(man["turn_deg"]) if r_mult is not None else None
                t_max = 60.0 if target is not None else man["straight_s"]
                start = len(rows)
            else:
                cmd = (0.0, 0.0)
                t_max = dur
            # per-manoeuvre state of the soil effects
            sink = [None, None]
            pile = [0.0, 0.0]
            t_seg = 0.0
            while True:
                if kind == "move":
                    if target is not None and abs(yaw - yaw0) >= target:
                        break
                    if target is None and t_seg >= t_max - 1e-9:
                        break
                    if t_seg > t_max:
                        break
                elif t_seg >= t_max - 1e-9:
                    break

                # wheel speed loop: first-order lag to the command
                a = [0.0, 0.0]
                for k in (0, 1):
                    nv = V[k] + (cmd[k] - V[k]) * (1.0 - math.exp(-DT / s["tau_w"]))
                    a[k] = (nv - V[k]) / DT
                    V[k] = nv
                # kinematics: Eq 2.1 / 2.2 with the terrain's slip track, angular slip Eq 6.3
                w_kin = (V[1] - V[0]) / bs_t
                slip = s["slip0"] if abs(w_kin) > 1e-6 else 0.0
                if self.active("angular-slip", test) and kind == "move" and r_mult is not None:
                    z = (r_mult - 1.0) / e["width"]
                    slip += e["A"] * math.exp(-z * z)        # peaks at R' (thesis Fig 6.8)
                w = w_kin * (1.0 - slip)
                v_y = 0.5 * (V[0] + V[1])
                yaw += w * DT

                # pitch: flat reference patch (roughness only) or an incline
                ar = 0.97 * ar + math.sqrt(1 - 0.97 ** 2) * nz.gauss(0.0, 1.0)
                pitch = s["pitch_rough_deg"] * ar
                if slope:
                    th = math.radians(e["theta_deg"])
                    pitch += math.degrees(math.atan(math.tan(th) * math.cos(yaw - psi_up)))
                sin_p = math.sin(math.radians(pitch))

                mu_f = rep_mu * (1.0 + 0.01 * nz.gauss(0.0, 1.0))   # +1 % sample-to-sample
                T = T0 * mu_f * math.tanh(abs(w_kin) / s["w0"]) * (1 if w_kin >= 0 else -1)
                Gs = s["G"] * rep_G
                lat = abs(w) * L / 2.0           # lateral skid speed of every wheel (v_x = 0)
                F = [0.0, 0.0]
                for k in (0, 1):
                    sgn = math.tanh(V[k] / 0.01)
                    F[k] = (T if k == 1 else -T)              # tread couple: right +T, left -T (T signed like w)
                    F[k] += Gs * sgn                          # rolling + internal resistance
                    F[k] += 0.55 * m * a[k]                   # accelerating half the rover (+10 %)
                    phi = e["Phi"] if slope else 1.0
                    F[k] += 0.5 * phi * m * G_ACC * sin_p     # Phi m g v_y sin(theta), Eq 1.16
                vg = [v_y + w * x_side[k] for k in (0, 1)]    # ground speed under each side
                t_in = t_seg

                # inner-drag: a side commanded backwards but dragged forwards (B/2 < R < R',
                # Section 2.1.2, slip angle beta > 90 deg Eq 5.1) must excavate the sand it is
                # pushed into: extra torque (Section 5.2, ~70 % more), growing as the pile grows.
                if self.active("inner-drag", test) and kind == "move":
                    for k in (0, 1):
                        if cmd[k] * vg[k] < 0.0 and abs(cmd[k]) > 1e-9:
                            shape = abs(vg[k]) / math.hypot(vg[k], lat)   # sin(beta - 90 deg)
                            ramp = 1.0 - math.exp(-t_in / e["tau_pile"])
                            F[k] += e["k"] * (T0 + s["G"]) * shape * ramp * math.tanh(V[k] / 0.01)

                # braked-inner: at R' the inner wheels are not commanded (V_i = 0) and are pushed
                # like a braked wheel (thesis 6.2, Fig 6.11): the outer side pays for the larger
                # sand resistance F_b times the inner wheels' ground speed.
                if self.active("braked-inner", test) and kind == "move" and r_mult == 1.0:
                    k_in = 0 if s["direction"] > 0 else 1
                    k_out = 1 - k_in
                    v_in = math.hypot(vg[k_in], lat)
                    Fb = e["k"] * s["mu"] * m * G_ACC / 2.0 * (1.0 - math.exp(-t_in / 0.3))
                    if abs(V[k_out]) > 1e-3:
                        F[k_out] += Fb * v_in / abs(V[k_out]) * math.copysign(1.0, V[k_out])

                # sinkage-bulldozing: each wheel sinks (dynamic sinkage, Eq 5.28 as a first-order
                # approach to a skid-dependent steady state) and pushes a growing sand pile beside
                # it: F_SB of Eq 5.35 with x_w the lateral displacement so far, capped where the
                # pile reaches the repose height (Eq 5.33, 5.36); power P_AS = F_SB v_ACT (Eq 5.37)
                # for two wheels per side (Eq 5.39), delivered by the motors in proportion to |V|.
                if self.active("sinkage-bulldozing", test) and kind == "move" and abs(w) > 1e-4:
                    P_as = 0.0
                    r_w = rv["wheel_radius_m"]
                    for k in (0, 1):
                        v_act = math.hypot(vg[k], lat)
                        sinb = lat / v_act if v_act > 1e-6 else 0.0
                        drag = 1.5 if cmd[k] * vg[k] < 0.0 else 1.0       # Appendix B
                        d_ss = e["d0"] * (1.0 + e["a"] * sinb * drag)
                        if sink[k] is None:
                            sink[k] = e["d0"]
                        sink[k] += (d_ss - sink[k]) * DT / e["tau_sink"]
                        d_avg = (1.0 + SINK_LAMBDA) * sink[k] / 2.0           # Eq 5.25
                        w_g = 2.0 * math.sqrt(d_avg * (2.0 * r_w - d_avg))    # Eq 5.26
                        x_max = w_g ** 2 / (2.0 * d_avg / math.tan(SOIL_PHI))
                        pile[k] = min(pile[k] + lat * DT, x_max)
                        width = w_g * sinb                                     # Eq 5.31
                        F_sb = width * SOIL_RHO * G_ACC * d_avg / 2.0 * \
                            (d_avg / math.tan(X_C) + 2.0 * pile[k]) / (1.0 / math.tan(X_C + SOIL_PHI))
                        P_as += 2.0 * F_sb * v_act * e["k"]
                    vs = abs(V[0]) + abs(V[1])
                    for k in (0, 1):
                        F[k] += P_as / vs * math.tanh(V[k] / 0.01) if vs > 1e-3 else 0.0

                # motor and driver: Eq 1.17-1.19 (P = tau w / eta + R_m I^2); a generating side
                # returns eta P to the bus only with regeneration, else the bus sees ~0.
                P_el = [0.0, 0.0]
                for k in (0, 1):
                    Rw = s["R_w"] * (1.0 + 0.00393 * dT[k])          # copper, +0.393 %/K
                    kF = s["k_F"] * (1.0 - 0.0012 * dT[k])           # NdFeB magnet: -0.12 %/K
                    I_m = F[k] / kF
                    P_cu = I_m * I_m * Rw
                    P_m = F[k] * V[k]
                    if P_m >= 0.0:
                        p = P_m / s["eta"] + P_cu
                    else:
                        p = s["eta"] * P_m + P_cu
                        if not s["regen"]:
                            p = max(p, 0.0)
                    P_el[k] = p
                    dT[k] += (P_cu - dT[k] / heat_R) / heat_C * DT
                    dT[k] = min(dT[k], 150.0)      # class-H insulation: the driver would cut out
                # battery: open-circuit voltage sagging with the total current (R_int), each
                # sensor behind its own wiring drop; I = P / V solved by fixed point.
                Voc = V0 - 0.0004 * t
                for _ in range(2):
                    Vb = Voc - s["R_int"] * (I_prev[0] + I_prev[1])
                    Vs = [Vb - s["R_wire"][k] * I_prev[k] for k in (0, 1)]
                    I_prev = [P_el[k] / Vs[k] + s["I_q"][k] for k in (0, 1)]
                meas_I = [round((s["gain"][k] * I_prev[k] + offset[k] + nz.gauss(0.0, s["sigma_i"])) / 0.0005) * 0.0005
                          for k in (0, 1)]
                meas_V = [round((Vs[k] + nz.gauss(0.0, 0.0015)) / 0.00125) * 0.00125 for k in (0, 1)]
                rows.append((t, meas_V[0], meas_I[0], meas_V[1], meas_I[1], cmd[0], cmd[1],
                             yaw + nz.gauss(0.0, 0.0003), pitch + nz.gauss(0.0, 0.02)))
                t += DT
                t_seg += DT
            if kind == "move":
                segs.append(dict(r_mult=r_mult, start=start, end=len(rows)))
        cool = math.exp(-PAUSE_S / (heat_R * heat_C))
        self.dT = [x * cool for x in dT]
        return rows, segs


def write_csv(path, rows):
    with open(path, "w") as f:
        f.write("t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,"
                "cmd_left_mps,cmd_right_mps,yaw_rad,pitch_deg\n")
        for r in rows:
            f.write(f"{r[0]:.4f},{r[1]:.5f},{r[2]:.4f},{r[3]:.5f},{r[4]:.4f},"
                    f"{r[5]:.6f},{r[6]:.6f},{r[7]:.5f},{r[8]:.3f}\n")


def seg_stats(rows, seg):
    """Mean per-side power, energy per side and duration of one manoeuvre (measured V x I)."""
    part = rows[seg["start"]:seg["end"]]
    n = max(1, len(part))
    P = [sum(r[1] * r[2] for r in part) / n, sum(r[3] * r[4] for r in part) / n]
    return P, [p * n * DT for p in P], n * DT


def regime_of(r_mult, rv, s, bs_ratio=1.0):
    """Name of the regime a commanded radius falls in (actual radius vs B/2, Section 2.1.2)."""
    if r_mult is None:
        return "straight"
    if r_mult == 0.0:
        return "point"
    if r_mult == 1.0:
        return "at-r-prime"
    if r_mult > 1.0:
        return "above-r-prime"
    r_act = r_mult * rv["slip_track_m"] / 2.0 * bs_ratio / (1.0 - s["slip0"])
    return "dragged-inner" if r_act > rv["track_width_m"] / 2.0 else "below-half-track"


def visibility(cls, runs, twin_runs):
    """Twin comparison over the test-run manoeuvres (rule in README.md). Returns the RMS of the
    per-manoeuvre, per-side differences, the pooled repeat sigma of the twin's manoeuvre-mean
    power, the radius (in R') where the mean |difference| is largest, and the largest
    |difference| of one (radius, side) averaged over the three test runs."""
    diffs, by_r, by_key, twin_p = [], {}, {}, {}
    for (rows, segs), (trows, tsegs) in zip(runs, twin_runs):
        for seg, tseg in zip(segs, tsegs):
            P, E, _ = seg_stats(rows, seg)
            tP, tE, td = seg_stats(trows, tseg)
            for k in (0, 1):
                if cls in ("angular-slip", "slip-track"):
                    dk = (E[k] - tE[k]) / td           # energy difference / nominal duration
                else:
                    dk = P[k] - tP[k]
                diffs.append(dk)
                by_r.setdefault(seg["r_mult"], []).append(abs(dk))
                by_key.setdefault((seg["r_mult"], k), []).append(dk)
                twin_p.setdefault((seg["r_mult"], k), []).append(tP[k])
    rms = math.sqrt(sum(x * x for x in diffs) / len(diffs))
    var = []
    for vals in twin_p.values():
        mean = sum(vals) / len(vals)
        var.append(sum((x - mean) ** 2 for x in vals) / (len(vals) - 1))
    sigma = math.sqrt(sum(var) / len(var))
    largest = max(by_r, key=lambda r: sum(by_r[r]) / len(by_r[r]))
    peak = max(abs(sum(v) / len(v)) for v in by_key.values())
    return rms, sigma, largest, peak


def generate(seed, out, count, rover_mode):
    os.makedirs(out, exist_ok=True)
    made = []
    for cls in CLASSES:
        for k in range(count):
            key = f"wd:{seed}:{cls}:{k}"
            srng = random.Random(key + ":structure")
            rover_name = rover_mode if rover_mode != "mixed" else \
                ("argo" if srng.random() < 0.25 else "husky")
            s = draw_structure(srng, rover_name)
            e = draw_effect(random.Random(key + ":effect"), cls, rover_name)
            sim = Sim(key, s, cls, e, True)
            d = os.path.join(out, f"{cls}-{seed}-{k}")
            os.makedirs(d, exist_ok=True)
            rv = ROVERS[rover_name]
            with open(os.path.join(d, "rover.toml"), "w") as f:
                for name in ("track_width_m", "length_m", "wheel_radius_m", "mass_kg", "slip_track_m"):
                    f.write(f"{name} = {rv[name]}\n")
            for i in range(2):
                rows, _ = sim.run(f"cal_{i}", False)
                write_csv(os.path.join(d, f"cal_{i}.csv"), rows)
            runs = []
            for i in range(3):
                rows, segs = sim.run(f"run_{i}", True)
                write_csv(os.path.join(d, f"run_{i}.csv"), rows)
                runs.append((rows, segs))
            truth = {"effect": "none" if cls == "control" else cls, "regime": REGIME[cls]}
            if cls != "control":
                twin = Sim(key, s, cls, e, False)
                for i in range(2):
                    twin.run(f"cal_{i}", False)              # same history of the windings
                twin_runs = [twin.run(f"run_{i}", True) for i in range(3)]
                rms, sigma, largest, peak = visibility(cls, runs, twin_runs)
                thr = max(1.5, 3.0 * sigma)
                if cls == "sinkage-bulldozing":
                    truth["regime"] = regime_of(largest, rv, s)
                truth.update(visible=rms > thr, twin_rms_w=round(rms, 3),
                             repeat_sigma_w=round(sigma, 3), threshold_w=round(thr, 3),
                             visible_local=peak > thr, largest_manoeuvre_diff_w=round(peak, 3),
                             largest_at_r_over_r_prime=largest)
            truth["rover"] = rover_name
            truth["params"] = {kk: (round(v, 4) if isinstance(v, float) else v) for kk, v in e.items()}
            truth["structure"] = {kk: (round(v, 4) if isinstance(v, float) else
                                       [round(x, 4) for x in v] if isinstance(v, list) else v)
                                  for kk, v in s.items()}
            with open(os.path.join(d, "truth.json"), "w") as f:
                json.dump(truth, f, indent=1)
            made.append((os.path.basename(d), truth))
    return made


def read_scenario(path):
    """The manoeuvres of a scenario file (`host-tool diagnose --next-runs`): turns
    (r_over_r_prime, angle_deg, v_c_mps, direction) and straights (distance_m, speed_mps),
    each as often as listed, the list `repeats` times."""
    import tomllib
    with open(path, "rb") as f:
        sc = tomllib.load(f)
    out = []
    for m in sc["manoeuvres"]:
        if m["kind"] == "turn":
            out.append(dict(r_mult=float(m["r_over_r_prime"]), turn_deg=float(m.get("angle_deg", 90.0)),
                            v_c=float(m.get("v_c_mps", 0.3)), straight_s=None,
                            direction=1 if m.get("direction", "left") == "left" else -1))
        elif m["kind"] == "straight":
            v = float(m.get("speed_mps", 0.3))
            out.append(dict(r_mult=None, turn_deg=None, v_c=v,
                            straight_s=float(m["distance_m"]) / v, direction=1))
        else:
            sys.exit(f"{path}: world D drives turns and straights, not {m['kind']!r}")
    return out * int(sc.get("repeats", 1))


def drive_scenario(dataset, scenario, rover_mode="mixed"):
    """Drives `scenario` in the world of `dataset` (a directory written by generate) as one
    more test run, after the runs already there (the windings carry their history), and
    writes it as the next run_<n>.csv. Returns its path."""
    cls, seed, k = os.path.basename(os.path.normpath(dataset)).rsplit("-", 2)
    key = f"wd:{seed}:{cls}:{k}"
    srng = random.Random(key + ":structure")
    rover_name = rover_mode if rover_mode != "mixed" else \
        ("argo" if srng.random() < 0.25 else "husky")
    s = draw_structure(srng, rover_name)
    e = draw_effect(random.Random(key + ":effect"), cls, rover_name)
    sim = Sim(key, s, cls, e, True)
    for i in range(2):
        sim.run(f"cal_{i}", False)
    n = 0
    while os.path.exists(os.path.join(dataset, f"run_{n}.csv")):
        if n < 3:
            sim.run(f"run_{n}", True)
        else:
            sim.run(f"run_{n}", True, drive=read_scenario(os.path.join(dataset, f"next_{n}.toml")))
        n += 1
    path = os.path.join(dataset, f"run_{n}.csv")
    drive = read_scenario(scenario)
    # Keep the scenario beside its run: a later drive replays it for the windings' history.
    with open(scenario, "rb") as src, open(os.path.join(dataset, f"next_{n}.toml"), "wb") as dst:
        dst.write(src.read())
    rows, _ = sim.run(f"run_{n}", True, drive=drive)
    write_csv(path, rows)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int)
    ap.add_argument("--out")
    ap.add_argument("--drive", metavar="SCENARIO.toml",
                    help="drive this scenario file in the world of --dataset as one more run")
    ap.add_argument("--dataset", metavar="DIR", help="with --drive: a dataset directory")
    ap.add_argument("--count-per-class", type=int, default=1)
    ap.add_argument("--rover", choices=["husky", "argo", "mixed"], default="mixed")
    a = ap.parse_args()
    if a.drive:
        if not a.dataset:
            ap.error("--drive needs --dataset")
        print(drive_scenario(a.dataset, a.drive, a.rover))
        return
    if a.seed is None or a.out is None:
        ap.error("--seed and --out are required (or --drive with --dataset)")
    t0 = time.time()
    made = generate(a.seed, a.out, a.count_per_class, a.rover)
    for name, tr in made:
        vis = "" if "visible" not in tr else \
            f"  visible={tr['visible']!s:5} rms={tr['twin_rms_w']:7.2f} W thr={tr['threshold_w']:.2f} W"
        print(f"{name:32} {tr['rover']:5} regime={tr['regime']!s:16}{vis}")
    print(f"{len(made)} datasets in {a.out} ({time.time() - t0:.1f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
