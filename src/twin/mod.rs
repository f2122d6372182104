//! The digital twin: a Rapier reduced-coordinate multibody of the robot model with drive
//! friction and rotor inertia injected into the physics, tracked by a torque controller;
//! motor power comes from the torque applied to Rapier and the motion Rapier produced.

pub mod record;
