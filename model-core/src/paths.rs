//! Energy-efficient circular arc – line – circular arc (CLC) paths (paper Section 3): the energy
//! of an arc (Theorem 1) and of a line (Lemma 1), the CLC geometry between two poses (Eq 47–50),
//! the energy of a CLC path (Eq 44–45) and of its point turn – line – point turn (PLP)
//! counterpart, and a derivative-free optimiser for the constrained problem of Eq 46.
//!
//! `f64`: planning runs on the host, but the module stays `no_std` and allocation-free.
//!
//! # Frame and sign conventions
//!
//! Everything is in the paper's path-defined frame (Fig. 5): A, the start, at the origin; C, the
//! end, at (d, 0); y^P to the left of A→C; headings measured from x^P, counter-clockwise
//! positive. θ_A and θ_C are the start and end headings, both in (0, π/2] or both in [−π/2, 0)
//! (Eq 50). With k = −sign(sin θ_A) (Eq 49), the first arc turns with the sign of k
//! (counter-clockwise for k = +1) and the second arc the other way. For θ_A, θ_C > 0, k = −1: the
//! rover, heading to the left of C, turns clockwise down to the line heading θ_B < 0, crosses
//! A→C on the line, and turns counter-clockwise up to θ_C — the "clockwise first and then
//! counterclockwise" of thesis Section 6.1. θ_B is therefore negative for positive θ_A, θ_C, as
//! in paper Table 3; negating both end headings mirrors the path (same radii and energy, θ_B
//! negated).
//!
//! # Energy laws
//!
//! The optimiser takes the energy law as a [`SegmentEnergy`]: the energy of an arc as a function
//! of its radius and turn angle, and the energy per metre of line. The paper's hard-ground model
//! ([`IcrHardGround`], Eq 21) is provided; [`FnLaw`] wraps any closure (e.g. a fitted sand
//! model).

use crate::power::IcrHardGround;
use core::f64::consts::{FRAC_PI_2, PI};

/// Energy of the two kinds of CLC segment under some power model.
pub trait SegmentEnergy {
    /// Energy of a circular arc of radius `radius_m` (0 = point turn) turned through
    /// `dtheta_rad` (its sign is ignored) [J]; paper Eq 26 for the hard-ground model. Return NaN
    /// for radii the law does not cover: the optimiser treats them as infeasible.
    fn arc_energy_j(&self, radius_m: f64, dtheta_rad: f64) -> f64;

    /// Energy per metre of straight line [J/m]; 2G for the hard-ground model (paper Eq 39).
    fn line_energy_j_per_m(&self) -> f64;

    /// A radius where the arc energy has a kink (R' for the hard-ground model, Eq 33–38). The
    /// optimiser evaluates it explicitly, so a minimum at the kink is found exactly. Default:
    /// none.
    fn kink_radius_m(&self) -> Option<f64> {
        None
    }
}

/// Paper Theorem 1 and Lemma 1 for the ICR hard-ground model (Eq 21–22).
impl SegmentEnergy for IcrHardGround {
    /// Paper Eq 26 (Heaviside form Eq 33–38): E_C = (F + G B_s)|Δθ| = a₁'|Δθ| for 0 ≤ R ≤ R',
    /// (F + 2RG)|Δθ| = (a₁' − a₂' + a₃'R)|Δθ| for R > R' [J]. NaN for a negative or NaN radius.
    fn arc_energy_j(&self, radius_m: f64, dtheta_rad: f64) -> f64 {
        let f = self.skid_moment_nm();
        let g = self.rolling_resistance_n;
        let turn_rad = libm::fabs(dtheta_rad);
        if radius_m.is_nan() || radius_m < 0.0 {
            f64::NAN
        } else if radius_m <= self.r_prime_m() {
            (f + g * self.slip_track_m) * turn_rad
        } else {
            (f + 2.0 * radius_m * g) * turn_rad
        }
    }

    /// Paper Lemma 1 (Eq 39): E_L = 2G · length, so 2G [J/m].
    fn line_energy_j_per_m(&self) -> f64 {
        2.0 * self.rolling_resistance_n
    }

    /// R' = B_s / 2 (paper Definition 1), where Eq 26 switches branch.
    fn kink_radius_m(&self) -> Option<f64> {
        Some(self.r_prime_m())
    }
}

/// An energy law made of a closure `arc_energy_j(radius_m, dtheta_rad) -> J` (the role of paper
/// Eq 26) and a line energy per metre (the role of Eq 39), e.g. for a fitted sand model.
#[derive(Clone, Copy)]
pub struct FnLaw<F> {
    /// Energy of an arc of radius `radius_m` turned through `dtheta_rad` (sign ignored) [J].
    pub arc_energy_j: F,
    /// Energy per metre of straight line [J/m].
    pub line_energy_j_per_m: f64,
    /// Radius where `arc_energy_j` has a kink, if any (see [`SegmentEnergy::kink_radius_m`]).
    pub kink_radius_m: Option<f64>,
}

impl<F> core::fmt::Debug for FnLaw<F> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("FnLaw")
            .field("line_energy_j_per_m", &self.line_energy_j_per_m)
            .field("kink_radius_m", &self.kink_radius_m)
            .finish_non_exhaustive()
    }
}

impl<F: Fn(f64, f64) -> f64> SegmentEnergy for FnLaw<F> {
    /// Calls the closure (the law's own Eq 26).
    fn arc_energy_j(&self, radius_m: f64, dtheta_rad: f64) -> f64 {
        (self.arc_energy_j)(radius_m, dtheta_rad)
    }

    /// The stored line energy per metre (the law's own Eq 39).
    fn line_energy_j_per_m(&self) -> f64 {
        self.line_energy_j_per_m
    }

    /// The stored kink radius.
    fn kink_radius_m(&self) -> Option<f64> {
        self.kink_radius_m
    }
}

/// Why a CLC path could not be built or optimised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathError {
    /// The start-to-end distance d is not a finite number > 0.
    InvalidDistance,
    /// θ_A, θ_C are not both in (0, π/2] or both in [−π/2, 0) (paper Eq 50), or not finite.
    HeadingsOutsideEq50,
    /// A radius is negative or not finite (paper Eq 46 needs R_j > 0; R = 0 is a point turn).
    InvalidRadius,
    /// The two arcs overlap: no straight line is tangent to both (Eq 47–48 have no solution),
    /// e.g. arcs too large for the distance.
    NoTangentLine,
    /// The tangent line exists but its heading breaks 0 < kθ_B ≤ π/2 (paper Eq 46). Eq 50 and
    /// a tangent line imply that bound (see [`ClcPath::new`]), so this only guards against
    /// rounding with radii near zero.
    LineHeadingOutsideEq46,
    /// The energy law gave no finite energy for any feasible path.
    NoFiniteEnergy,
}

impl core::fmt::Display for PathError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            PathError::InvalidDistance => "start-to-end distance must be finite and > 0",
            PathError::HeadingsOutsideEq50 => {
                "start and end headings must both be in (0, pi/2] or both in [-pi/2, 0) (Eq 50)"
            }
            PathError::InvalidRadius => "arc radii must be finite and >= 0",
            PathError::NoTangentLine => "the arcs overlap: no line is tangent to both",
            PathError::LineHeadingOutsideEq46 => "line heading outside 0 < k theta_B <= pi/2",
            PathError::NoFiniteEnergy => "the energy law gave no finite energy",
        })
    }
}

/// A point in the path-defined frame (paper Fig. 5) [m].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathPoint {
    /// x^P, along A→C [m].
    pub x_m: f64,
    /// y^P, to the left of A→C [m].
    pub y_m: f64,
}

/// `90f64.to_radians()` may round one ulp above π/2; headings this close to ±π/2 count as ±π/2.
const HEADING_SLACK_RAD: f64 = 1e-12;

/// Start and end of a CLC path in the path-defined frame (paper Fig. 5): A = (0, 0) with heading
/// θ_A, C = (d, 0) with heading θ_C, validated against paper Eq 50.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClcEnds {
    start_heading_rad: f64,
    end_heading_rad: f64,
    distance_m: f64,
}

impl ClcEnds {
    /// θ_A, θ_C both in (0, π/2] or both in [−π/2, 0) (paper Eq 50), d finite and > 0.
    pub fn new(
        start_heading_rad: f64,
        end_heading_rad: f64,
        distance_m: f64,
    ) -> Result<Self, PathError> {
        if !(distance_m.is_finite() && distance_m > 0.0) {
            return Err(PathError::InvalidDistance);
        }
        let max = FRAC_PI_2 + HEADING_SLACK_RAD;
        let in_first = |t: f64| t > 0.0 && t <= max;
        let in_fourth = |t: f64| t < 0.0 && t >= -max;
        let (a, c) = (start_heading_rad, end_heading_rad);
        if !((in_first(a) && in_first(c)) || (in_fourth(a) && in_fourth(c))) {
            return Err(PathError::HeadingsOutsideEq50);
        }
        Ok(Self {
            start_heading_rad: a.clamp(-FRAC_PI_2, FRAC_PI_2),
            end_heading_rad: c.clamp(-FRAC_PI_2, FRAC_PI_2),
            distance_m,
        })
    }

    /// θ_A^P [rad].
    pub fn start_heading_rad(&self) -> f64 {
        self.start_heading_rad
    }

    /// θ_C^P [rad].
    pub fn end_heading_rad(&self) -> f64 {
        self.end_heading_rad
    }

    /// d = |AC| [m].
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// k = −sin θ_A / |sin θ_A| (paper Eq 49): −1 when the first arc turns clockwise.
    pub fn turn_sign(&self) -> f64 {
        if self.start_heading_rad > 0.0 {
            -1.0
        } else {
            1.0
        }
    }

    /// The mirror image about A→C: both headings negated (Eq 50's other quadrant).
    pub fn mirrored(&self) -> Self {
        Self {
            start_heading_rad: -self.start_heading_rad,
            end_heading_rad: -self.end_heading_rad,
            distance_m: self.distance_m,
        }
    }
}

/// Paper Eq 49: the ends B1 (of the first arc) and B2 (of the second arc) of the line, for arc
/// radii R1, R2 and line heading θ_B:
/// B1 = A + kR1(−sin θ_A + sin θ_B, cos θ_A − cos θ_B),
/// B2 = C + kR2(sin θ_C − sin θ_B, −cos θ_C + cos θ_B).
pub fn line_ends(
    ends: &ClcEnds,
    r1_m: f64,
    r2_m: f64,
    line_heading_rad: f64,
) -> (PathPoint, PathPoint) {
    let k = ends.turn_sign();
    let (sa, ca) = libm::sincos(ends.start_heading_rad);
    let (sc, cc) = libm::sincos(ends.end_heading_rad);
    let (sb, cb) = libm::sincos(line_heading_rad);
    (
        PathPoint {
            x_m: k * r1_m * (-sa + sb),
            y_m: k * r1_m * (ca - cb),
        },
        PathPoint {
            x_m: ends.distance_m + k * r2_m * (sc - sb),
            y_m: k * r2_m * (-cc + cb),
        },
    )
}

/// Paper Eq 47–48: the equality constraints [h1, h2] [m], both zero when the line B1→B2 has
/// heading θ_B (is tangent to both arcs and driven forwards).
pub fn constraint_residuals_m(b1: PathPoint, b2: PathPoint, line_heading_rad: f64) -> [f64; 2] {
    let dx = b2.x_m - b1.x_m;
    let dy = b2.y_m - b1.y_m;
    [
        dx - libm::cos(line_heading_rad) * libm::hypot(dx, dy),
        dy - dx * libm::tan(line_heading_rad),
    ]
}

/// A CLC path between given [`ClcEnds`] (paper Fig. 5): arc A→B1 of radius R1, line B1→B2 at
/// heading θ_B, arc B2→C of radius R2. R = 0 is a point turn, so R1 = R2 = 0 is the PLP path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClcPath {
    /// R1 [m].
    pub r1_m: f64,
    /// R2 [m].
    pub r2_m: f64,
    /// θ_B^P, the heading of the line [rad]; negative for positive θ_A, θ_C.
    pub line_heading_rad: f64,
    /// B1, the end of the first arc (paper Eq 49).
    pub b1: PathPoint,
    /// B2, the start of the second arc (paper Eq 49).
    pub b2: PathPoint,
    /// |B1B2| [m].
    pub line_length_m: f64,
    /// |θ_B − θ_A|, the turn of the first arc [rad].
    pub first_turn_rad: f64,
    /// |θ_B − θ_C|, the turn of the second arc [rad].
    pub second_turn_rad: f64,
}

impl ClcPath {
    /// Solves the equality constraints h1 = h2 = 0 (paper Eq 47–49) for θ_B given R1, R2 ≥ 0,
    /// and checks 0 < kθ_B ≤ π/2 (Eq 46; kθ_B = 0 only for R1 = R2 = 0, the PLP path).
    ///
    /// Closed form rather than root finding: Eq 49 is B1 = O1 + kR1 n(θ_B),
    /// B2 = O2 − kR2 n(θ_B) with n(θ) = (sin θ, −cos θ), the arcs' centres
    /// O1 = A + kR1(−sin θ_A, cos θ_A), O2 = C + kR2(sin θ_C, −cos θ_C), so
    /// B2 − B1 = Δ − k(R1 + R2) n(θ_B) with Δ = O2 − O1 = |Δ|(cos φ, sin φ). Eq 47–48 say
    /// B2 − B1 = ℓ (cos θ_B, sin θ_B) with ℓ ≥ 0, i.e. n(θ_B)·Δ = |Δ| sin(θ_B − φ) = k(R1 + R2)
    /// and ℓ = |Δ| cos(θ_B − φ) ≥ 0: the inner tangent of the two circles,
    /// θ_B = φ + asin(k(R1 + R2)/|Δ|), ℓ = √(|Δ|² − (R1 + R2)²). It exists iff |Δ| ≥ R1 + R2
    /// (otherwise [`PathError::NoTangentLine`]), and it is the only forward tangent, so no
    /// bracket or iteration can miss or confuse roots.
    ///
    /// Eq 46's bound on θ_B then holds by itself. Take k = −1 (the other case is the mirror
    /// image): Δ_y = R1 cos θ_A + R2 cos θ_C ≥ 0 puts φ in [0, π], so θ_B ≥ −π/2; θ_B = 0 would
    /// need Δ_y = R1 + R2, impossible for θ_A, θ_C ≠ 0 and R1 + R2 > 0; and the radii with a
    /// tangent line form a star around R1 = R2 = 0 (|Δ|² − (R1 + R2)² is a quadratic in the
    /// scale t of (R1, R2) with a non-positive t² coefficient and the value d² > 0 at t = 0),
    /// along which θ_B starts just below 0 and so, by continuity, stays negative.
    pub fn new(ends: &ClcEnds, r1_m: f64, r2_m: f64) -> Result<Self, PathError> {
        if !(r1_m.is_finite() && r1_m >= 0.0 && r2_m.is_finite() && r2_m >= 0.0) {
            return Err(PathError::InvalidRadius);
        }
        let k = ends.turn_sign();
        let (sa, ca) = libm::sincos(ends.start_heading_rad);
        let (sc, cc) = libm::sincos(ends.end_heading_rad);
        let dx = ends.distance_m + k * (r2_m * sc + r1_m * sa);
        let dy = -k * (r2_m * cc + r1_m * ca);
        let centre_distance_m = libm::hypot(dx, dy);
        let radii_m = r1_m + r2_m;
        if !centre_distance_m.is_finite() || centre_distance_m < radii_m {
            return Err(PathError::NoTangentLine);
        }
        let ratio = if radii_m == 0.0 {
            0.0
        } else {
            (radii_m / centre_distance_m).min(1.0)
        };
        let theta_b = wrap_rad(libm::atan2(dy, dx) + libm::asin(k * ratio));
        let k_theta_b = k * theta_b;
        let plp = radii_m == 0.0;
        if !((k_theta_b > 0.0 || (plp && k_theta_b == 0.0)) && k_theta_b <= FRAC_PI_2) {
            return Err(PathError::LineHeadingOutsideEq46);
        }
        let (b1, b2) = line_ends(ends, r1_m, r2_m, theta_b);
        // ℓ = |Δ| cos(θ_B − φ), written so that it cannot overflow for huge d.
        let line_length_m = centre_distance_m * libm::sqrt((1.0 - ratio) * (1.0 + ratio));
        Ok(Self {
            r1_m,
            r2_m,
            line_heading_rad: theta_b,
            b1,
            b2,
            line_length_m,
            first_turn_rad: libm::fabs(theta_b - ends.start_heading_rad),
            second_turn_rad: libm::fabs(theta_b - ends.end_heading_rad),
        })
    }

    /// The PLP path with the same ends (paper Table 3 "PLP"): R1 = R2 = 0, θ_B = 0, a point turn
    /// through |θ_A|, the line A→C of length d, a point turn through |θ_C|.
    pub fn plp(ends: &ClcEnds) -> Self {
        Self {
            r1_m: 0.0,
            r2_m: 0.0,
            line_heading_rad: 0.0,
            b1: PathPoint::default(),
            b2: PathPoint {
                x_m: ends.distance_m,
                y_m: 0.0,
            },
            line_length_m: ends.distance_m,
            first_turn_rad: libm::fabs(ends.start_heading_rad),
            second_turn_rad: libm::fabs(ends.end_heading_rad),
        }
    }

    /// Paper Eq 44–45: E = E_AB1 + E_B1B2 + E_B2C [J] under `law`.
    pub fn energy_j(&self, law: &impl SegmentEnergy) -> f64 {
        law.arc_energy_j(self.r1_m, self.first_turn_rad)
            + law.line_energy_j_per_m() * self.line_length_m
            + law.arc_energy_j(self.r2_m, self.second_turn_rad)
    }
}

/// Wraps an angle in (−3π/2, 3π/2] into (−π, π].
fn wrap_rad(theta: f64) -> f64 {
    if theta > PI {
        theta - 2.0 * PI
    } else if theta <= -PI {
        theta + 2.0 * PI
    } else {
        theta
    }
}

/// The optimiser stops refining a radius once its golden-section bracket is this narrow [m].
pub const RADIUS_TOLERANCE_M: f64 = 1e-7;

/// Grid steps per radius over the search range [0, d] (start grid and each 1-D search).
const GRID_STEPS: usize = 12;
/// Bound on golden-section iterations per 1-D search: enough to shrink a bracket of 10¹⁶ m to
/// the tolerance (each iteration multiplies it by 0.618).
const MAX_GOLDEN_ITERATIONS: usize = 120;
/// The radius search reaches at least this many kink radii (R'), whatever the distance.
const KINK_RANGE_FACTOR: f64 = 4.0;
/// Bound on coordinate sweeps (the hard-ground cases need one or two).
const MAX_SWEEPS: usize = 50;

/// The optimum of paper Eq 46 for given ends and energy law, with the PLP energy for comparison
/// (paper Table 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClcOptimum {
    /// E of the optimal CLC path (Eq 45) [J].
    pub energy_j: f64,
    /// R1* [m].
    pub r1_m: f64,
    /// R2* [m].
    pub r2_m: f64,
    /// θ_B* [rad] (negative for positive θ_A, θ_C).
    pub line_heading_rad: f64,
    /// |B1B2| [m].
    pub line_length_m: f64,
    /// E of the PLP path with the same ends [J] (may be non-finite if `law` excludes R = 0).
    pub plp_energy_j: f64,
}

/// Minimises the CLC energy (paper Eq 45) over R1, R2 subject to Eq 47–50 (paper Eq 46), θ_B
/// following from the radii ([`ClcPath::new`]). `ClcPath::new(ends, r1_m, r2_m)` rebuilds the
/// optimal geometry.
///
/// Radii are searched in [0, r_max] with r_max = max(d, 4 × the law's kink radius): R = 0 (a
/// point turn, the closure of Eq 46's R_j > 0) is admitted so the result is never worse than
/// the PLP path, and R' (with room to 2–2.5 R', the seed's sand optimum) is always reachable,
/// even when the start-to-end distance d is shorter. Infeasible radii and non-finite energies count as
/// +∞.
///
/// Method: a 13 × 13 grid over [0, r_max]², r_max = max(d, 4 × the law's kink radius) (plus
/// the kink radius on each axis) picks the start, then cyclic coordinate minimisation: each radius in turn is minimised over the whole
/// range [0, r_max] with the other fixed, by a 13-point scan plus the kink radius and the current
/// value, refined by golden-section search in the cells either side of the best point (to
/// [`RADIUS_TOLERANCE_M`]). Sweeps stop when neither radius moves by more than the tolerance, or
/// after 50 sweeps.
///
/// Why this and not Nelder–Mead or a gradient method: E has kinks where an arc's law switches
/// branch (R' on hard ground, Eq 26), and the minimum sits on them. Each arc's energy depends on
/// its own radius only, so these kinks lie on the lines R1 = const and R2 = const, and
/// coordinate-wise minimisation does not stall on axis-aligned kinks (its classic failure needs
/// a kink across the axes, such as one in R1 − R2), whereas a Nelder–Mead simplex tends to
/// collapse onto a kink ridge; golden section needs no derivative. Scanning the whole range in
/// each 1-D search copes with laws whose energy is not unimodal in R. Known limit: a minimum on
/// the feasibility boundary (arcs touching, |O1O2| = R1 + R2, not axis-aligned) could be
/// approached short of the boundary; none of the hard-ground optima in the tests lies there.
///
/// At most 14² + 50 · 2 · (14 + 122) ≈ 14 000 path evaluations; the Table 3 cases take about
/// 160 (≈ 30 µs on the host, `cargo bench -p model-core --bench clc`).
pub fn optimise_clc(law: &impl SegmentEnergy, ends: &ClcEnds) -> Result<ClcOptimum, PathError> {
    // Radii beyond d can pay off when the turns are shallow (θ 0.05 rad, d 0.5 m: R' = 0.645 m
    // beats anything ≤ d), and on sand the seed finds optima near 2–2.5 R' (Table 6.1).
    let r_max_m = law
        .kink_radius_m()
        .filter(|r| r.is_finite() && *r > 0.0)
        .map_or(ends.distance_m, |kink| {
            ends.distance_m.max(KINK_RANGE_FACTOR * kink)
        });
    let kink_m = law
        .kink_radius_m()
        .filter(|r| r.is_finite() && *r >= 0.0 && *r <= r_max_m);
    let energy = |r1_m: f64, r2_m: f64| -> f64 {
        match ClcPath::new(ends, r1_m, r2_m) {
            Ok(path) => {
                let e = path.energy_j(law);
                if e.is_finite() {
                    e
                } else {
                    f64::INFINITY
                }
            }
            Err(_) => f64::INFINITY,
        }
    };

    // Start: best point of the grid (with the kink radius on both axes).
    let step_m = r_max_m / GRID_STEPS as f64;
    let grid = |i: usize| -> Option<f64> {
        match i {
            0..=GRID_STEPS => Some(i as f64 * step_m),
            _ => kink_m,
        }
    };
    let mut best = (0.0, 0.0, energy(0.0, 0.0));
    for i in 0..=GRID_STEPS + 1 {
        for j in 0..=GRID_STEPS + 1 {
            if let (Some(r1), Some(r2)) = (grid(i), grid(j)) {
                let e = energy(r1, r2);
                if e < best.2 {
                    best = (r1, r2, e);
                }
            }
        }
    }

    for _ in 0..MAX_SWEEPS {
        let (r1_old, r2_old, _) = best;
        let (r1, e1) = minimise_radius(|r| energy(r, best.1), best.0, best.2, r_max_m, kink_m);
        best = (r1, best.1, e1);
        let (r2, e2) = minimise_radius(|r| energy(best.0, r), best.1, best.2, r_max_m, kink_m);
        best = (best.0, r2, e2);
        if libm::fabs(best.0 - r1_old) <= RADIUS_TOLERANCE_M
            && libm::fabs(best.1 - r2_old) <= RADIUS_TOLERANCE_M
        {
            break;
        }
    }

    let (r1_m, r2_m, energy_j) = best;
    if !energy_j.is_finite() {
        return Err(PathError::NoFiniteEnergy);
    }
    let path = ClcPath::new(ends, r1_m, r2_m)?;
    Ok(ClcOptimum {
        energy_j,
        r1_m,
        r2_m,
        line_heading_rad: path.line_heading_rad,
        line_length_m: path.line_length_m,
        plp_energy_j: ClcPath::plp(ends).energy_j(law),
    })
}

/// One coordinate step of [`optimise_clc`]: minimises `f` over [0, r_max_m] starting from
/// (`r_m`, `e_j`). Never returns a worse point than the one it was given.
fn minimise_radius(
    f: impl Fn(f64) -> f64,
    r_m: f64,
    e_j: f64,
    r_max_m: f64,
    kink_m: Option<f64>,
) -> (f64, f64) {
    let step_m = r_max_m / GRID_STEPS as f64;
    let mut best = (r_m, e_j);
    let candidates = (0..=GRID_STEPS).map(|i| i as f64 * step_m).chain(kink_m);
    for r in candidates {
        let e = f(r);
        if e < best.1 {
            best = (r, e);
        }
    }
    let lo = (best.0 - step_m).max(0.0);
    let hi = (best.0 + step_m).min(r_max_m);
    let golden =
        crate::search::golden_section_min(&f, lo, hi, RADIUS_TOLERANCE_M, MAX_GOLDEN_ITERATIONS);
    if golden.1 < best.1 {
        best = golden;
    }
    best
}

#[cfg(test)]
mod tests;
