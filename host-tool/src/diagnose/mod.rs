//! `diagnose`: where the hard-ground ICR model (paper Eq 21, fitted on calibration manoeuvres)
//! departs from measured power, which catalogued unmodelled effect explains it, and how much of
//! the held-out gap it closes. Work in progress: see `NOTES.md` in this directory.

pub mod baseline;
pub mod features;

#[cfg(test)]
mod tests;
