//! Kinematics of the serial chain: forward kinematics, the geometric Jacobian, closed-form
//! inverse kinematics for the OPW class (IRB 1200 and similar arms) and damped least squares
//! for any chain.
//!
//! Poses are in the base frame (frame 0 of the model, the URDF root link) unless stated
//! otherwise; link frames are the MDH frames of [`crate::model`]. The flange frame is the
//! model's ([`crate::Robot::flange`]); a TCP is given by its pose in the flange frame. Units
//! are m and rad; joint angles are the model's (URDF) joint coordinates.

pub mod dls;
pub mod fk;
pub mod ik;
pub mod jacobian;
