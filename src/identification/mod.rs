//! Parameter identification from motor power (Liu et al. 2018, eqs. 9–13), and the signal
//! processing that turns a logged stream into regressor inputs. [`excitation`] designs the
//! trajectories that make the identified parameters well conditioned (paper eqs. 7–8).
//! [`consistency`] checks an identified model for physical consistency, and [`consistent`]
//! projects one onto physically consistent standard parameters.

pub mod consistency;
pub mod consistent;
pub mod data;
pub mod energy;
pub mod excitation;
pub mod excitation_set;
pub mod fit;
pub mod fourier_fit;
pub mod last_link;
pub mod linear;
pub mod lsq;
pub mod model;
pub mod plan;
pub mod pmsm;
pub mod prior;
mod rests;
pub mod spline;
pub mod states;
pub mod steps;
pub mod tuning;
