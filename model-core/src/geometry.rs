//! Rover geometry and mass.

use serde::{Deserialize, Serialize};

/// Rigid geometry and mass of a four-wheel skid-steer rover, plus the slip track its controller
/// uses to turn (v, ω) commands into side speeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rover {
    /// B: distance between the left and right wheel centres [m].
    pub track_width_m: f32,
    /// L: distance between the front and rear axles [m].
    pub length_m: f32,
    /// r: wheel radius [m].
    pub wheel_radius_m: f32,
    /// m: mass [kg].
    pub mass_kg: f32,
    /// B_s: slip track (distance between the left and right ICRs, Eq 1.4) [m].
    pub slip_track_m: f32,
}

impl Rover {
    /// Clearpath Husky A200 as configured in the seed (Table 3.2; controller slip track 1.1 m).
    pub const HUSKY_A200: Rover = Rover {
        track_width_m: 0.545,
        length_m: 0.52,
        wheel_radius_m: 0.165,
        mass_kg: 63.0,
        slip_track_m: 1.1,
    };

    /// Eq 2.5: R' = B_s / 2, the radius at which the inner wheels are commanded to stand still.
    pub fn r_prime_m(&self) -> f32 {
        self.slip_track_m / 2.0
    }

    /// R_c = B / 2: the turning centre sits on the inner wheels' track.
    pub fn half_track_m(&self) -> f32 {
        self.track_width_m / 2.0
    }

    /// The same rover with another slip track (e.g. one measured on a terrain, Appendix D).
    pub fn with_slip_track(self, slip_track_m: f32) -> Self {
        Self {
            slip_track_m,
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn husky_r_prime_is_half_the_controller_slip_track() {
        let husky = Rover::HUSKY_A200;
        assert!((husky.r_prime_m() - 0.55).abs() < 1e-6);
        // R_c = B/2 lies below R' for the Husky: the dragged-inner regime exists.
        assert!(husky.half_track_m() < husky.r_prime_m());
        assert!((husky.half_track_m() - 0.2725).abs() < 1e-6);
    }
}
