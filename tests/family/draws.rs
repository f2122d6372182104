//! Drawing robots of the family: reproducible draws within the table, pinned effects, and
//! bad tables refused.

use super::*;

/// Robot `seed` of the family `table` draws around the IRB 1200's files and realistic rig.
fn draw_plant(table: &FamilyTable, seed: u64) -> powertwin::twin::family::Plant {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let rig = common::irb1200_rig(
        &robot,
        &drive,
        Fidelity::Realistic,
        NoiseSettings::default(),
    );
    table
        .draw(&robot, &drive, &rig.twin, &rig.sensor, seed)
        .unwrap()
}

#[test]
fn a_draw_is_reproducible_and_within_the_table() {
    let robot = common::irb1200();
    let drive = common::irb1200_drive(&robot);
    let table = FamilyTable::default();
    let draw = |seed| draw_plant(&table, seed);
    let (a, b, c) = (draw(7), draw(7), draw(8));
    assert_eq!(a.draw, b.draw);
    assert_ne!(a.draw, c.draw);
    for seed in 0..20 {
        let p = draw(seed);
        for (i, l) in p.robot.links().iter().enumerate() {
            let nominal = &robot.links()[i].inertia;
            let rel = l.inertia.mass / nominal.mass - 1.0;
            assert!(rel.abs() <= 0.2 + 1e-12, "link {i} mass off by {rel}");
            assert!((l.inertia.com - nominal.com).amax() <= 0.02 + 1e-12);
        }
        for (t, n) in p.drive.joints().iter().zip(drive.joints()) {
            let rel = t.friction.coulomb / n.friction.coulomb - 1.0;
            assert!(rel.abs() <= 0.5 + 1e-12);
            let peak = t.unmodelled.stribeck_static.unwrap() / t.friction.coulomb;
            assert!((1.1..=1.6).contains(&peak), "Stribeck peak {peak}");
            assert!((0.0..=0.04).contains(&t.unmodelled.gear_friction_braking));
            assert!((t.standby_power / n.standby_power - 1.0).abs() <= 0.2 + 1e-12);
        }
        let s = &p.sensor;
        assert!(
            [
                10.0, 20.0, 25.0, 40.0, 50.0, 100.0, 125.0, 200.0, 250.0, 500.0
            ]
            .contains(&s.rate_hz)
        );
        assert!(s.stamp_jitter_s <= 0.2 / s.rate_hz + 1e-12);
        assert!((0.0..=0.04 + 1e-12).contains(&s.power_lag_s));
        assert_eq!(p.twin.fidelity, Fidelity::Realistic);
        assert!((0.0..=0.2).contains(&p.twin.nominal_error));
    }
    // The user's files stay as they were.
    assert_eq!(
        robot.links()[1].inertia,
        common::irb1200().links()[1].inertia
    );
}

/// A table that pins effects (ranges of zero width) draws every other effect as the default
/// table does: an ablation compares the same robots with and without those effects.
#[test]
fn pinning_an_effect_leaves_the_other_draws_alone() {
    let default = FamilyTable::default();
    let pinned = FamilyTable {
        mass_rel: 0.0,
        stribeck_peak: [1.3, 1.3],
        gear_friction: [0.0, 0.0],
        rate_hz: [100.0, 100.0],
        power_lag_s: [0.02, 0.02],
        ..default.clone()
    };
    for seed in [1, 2_000_030] {
        let draw = |t: &FamilyTable| draw_plant(t, seed).draw;
        let (a, b) = (draw(&default), draw(&pinned));
        // The pinned effects take their values.
        assert!(b.link_mass_error_rel.iter().all(|&e| e == 0.0));
        assert_eq!(b.rate_hz, 100.0);
        assert!((b.power_lag_s - 0.02).abs() < 1e-12, "{}", b.power_lag_s);
        for j in &b.joints {
            assert!((j.stribeck_static_nm / j.coulomb_nm - 1.3).abs() < 1e-12);
            assert_eq!(
                (j.gear_friction_per_nm, j.gear_friction_braking_per_nm),
                (0.0, 0.0)
            );
        }
        // Every other effect is the default table's draw.
        let other = |d: &powertwin::twin::family::Draw| {
            let joints: Vec<_> = d
                .joints
                .iter()
                .map(|j| (j.coulomb_nm, j.viscous_nms_per_rad, j.stribeck_speed_rad_s))
                .collect();
            (joints, d.cabinet_w, d.bandwidth_rad_s, d.nominal_error)
        };
        assert_eq!(other(&a), other(&b), "seed {seed}");
        assert_eq!(a.power_averaging, b.power_averaging);
        assert_eq!(a.power_sigma_w, b.power_sigma_w);
        // The jitter is drawn in sample periods.
        let periods = |d: &powertwin::twin::family::Draw| d.stamp_jitter_s * d.rate_hz;
        assert!((periods(&a) - periods(&b)).abs() < 1e-12, "seed {seed}");
    }
}

#[test]
fn bad_family_tables_are_refused_with_the_key() {
    for (text, key) in [
        ("gear_friction = [0.04, 0.0]", "gear_friction"),
        ("power_lag_s = [-0.01, 0.02]", "power_lag_s"),
        ("mass_rel = -0.2", "mass_rel"),
        ("cabinet_seen = 1.5", "cabinet_seen"),
        ("rate_hz = [10.0, nan]", "rate_hz"),
        ("no_such_key = 1.0", "no_such_key"),
    ] {
        let e = FamilyTable::from_toml_str(text, "family.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("family.toml") && e.contains(key), "{text}: {e}");
    }
    let t = FamilyTable::from_toml_str("mass_rel = 0.1", "family.toml").unwrap();
    assert_eq!(t.mass_rel, 0.1);
    assert_eq!(t.com_m, FamilyTable::default().com_m);
}
