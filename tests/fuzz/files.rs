//! Fuzzing the readers of model, drive, payload, scenario, trajectory and model.json files.

use super::*;

#[test]
fn urdf_loader() {
    let seeds = vec![
        model_file("models/irb1200_7_70.urdf"),
        model_file("tests/data/ur5.urdf"),
        model_file("tests/data/panda.urdf"),
    ];
    fuzz("urdf", &seeds, cases(400), |b| {
        if let Ok(robot) = load_str(&text(b), &LoadOptions::default())
            && let Ok(mut s) = StateSampler::new(&robot, 3.0, 10.0, 1)
        {
            let _ = s.pose();
        }
    });
    // Certainly invalid: each is an error, not a robot.
    let urdf = builtin::IRB1200_URDF;
    let mass = urdf.find("<mass value=\"").unwrap() + "<mass value=\"".len();
    let end = mass + urdf[mass..].find('"').unwrap();
    for bad_mass in ["-1", "nan", "inf", "0"] {
        let t = format!("{}{bad_mass}{}", &urdf[..mass], &urdf[end..]);
        assert!(
            load_str(&t, &LoadOptions::default()).is_err(),
            "mass {bad_mass}"
        );
    }
    for (lim, why) in [
        (r#"lower="2" upper="-2""#, "inverted limits"),
        (r#"lower="nan" upper="2""#, "NaN limit"),
    ] {
        let t = with(urdf, r#"lower="-2.967059728" upper="2.967059728""#, lim);
        assert!(load_str(&t, &LoadOptions::default()).is_err(), "{why}");
    }
    let t = with(urdf, r#"velocity="5.026548246""#, r#"velocity="-1""#);
    assert!(
        load_str(&t, &LoadOptions::default()).is_err(),
        "negative velocity"
    );
}

#[test]
fn drive_payload_scenario_and_noise_readers() {
    let robot = common::irb1200();
    let drives = vec![
        model_file("models/irb1200_7_70.drive.toml"),
        model_file("models/ideal.drive.toml"),
    ];
    fuzz("drive", &drives, cases(500), |b| {
        let _ = Drive::from_toml_str(&text(b), "fuzz", &robot);
    });
    let payloads: Vec<Vec<u8>> = ["tool_1p32kg", "load_1kg", "load_2kg", "load_4kg"]
        .iter()
        .map(|n| model_file(&format!("models/{n}.payload.toml")))
        .collect();
    fuzz("payload", &payloads, cases(500), |b| {
        let _ = Payload::from_toml_str(&text(b), "fuzz");
    });
    let scenario = vec![model_file("scenarios/pick_and_place.toml")];
    fuzz("scenario", &scenario, cases(500), |b| {
        let _ = Scenario::from_toml_str(&text(b), "fuzz");
    });
    let noise = "encoder_resolution_rad = 6e-6\nencoder_sigma_rad = 1e-5\n\
                 joint_power_sigma_W = 0.5\npower_sigma_W = 1.0\npower_offset_W = 0.0\n";
    assert!(NoiseSettings::from_toml_str(noise, "noise").is_ok());
    fuzz("noise", &[noise.as_bytes().to_vec()], cases(500), |b| {
        let _ = NoiseSettings::from_toml_str(&text(b), "fuzz");
    });

    // Certainly invalid values are errors.
    let drive = builtin::IRB1200_DRIVE;
    for bad in ["nan", "inf", "1.5", "-0.87", "0"] {
        let t = with(drive, "efficiency = 0.87", &format!("efficiency = {bad}"));
        assert!(
            Drive::from_toml_str(&t, "d", &robot).is_err(),
            "efficiency {bad}"
        );
    }
    for bad in ["-7.0", "nan", "0.0"] {
        let t = with(
            drive,
            "rated_payload_kg = 7.0",
            &format!("rated_payload_kg = {bad}"),
        );
        assert!(
            Drive::from_toml_str(&t, "d", &robot).is_err(),
            "rated payload {bad}"
        );
    }
    let tool = text(&payloads[0]);
    for bad in ["-1.32", "nan", "inf", "0.0"] {
        let t = with(&tool, "mass_kg = 1.32", &format!("mass_kg = {bad}"));
        assert!(Payload::from_toml_str(&t, "p").is_err(), "mass {bad}");
    }
    let sc = text(&scenario[0]);
    let t = with(&sc, "A = [0.40, 0.00, 0.40]", "A = [nan, 0.00, 0.40]");
    assert!(Scenario::from_toml_str(&t, "s").is_err(), "NaN via point");
    for bad in ["-1.0", "nan"] {
        let t = with(
            noise,
            "power_sigma_W = 1.0",
            &format!("power_sigma_W = {bad}"),
        );
        assert!(
            NoiseSettings::from_toml_str(&t, "n").is_err(),
            "noise {bad}"
        );
    }
}

#[test]
fn trajectory_table_reader() {
    let seeds = vec![
        trajectory_csv(12).into_bytes(),
        trajectory_csv(3).into_bytes(),
    ];
    fuzz("trajectory", &seeds, cases(800), |b| {
        if let Ok(table) = Table::parse(&text(b), "fuzz.csv")
            && let Ok(traj) = Sampled::from_table(&table, 6)
        {
            let (mut q, mut dq, mut ddq) = ([0.0; 6], [0.0; 6], [0.0; 6]);
            for f in [0.0, 0.37, 1.0] {
                traj.sample(f * traj.duration(), &mut q, &mut dq, &mut ddq);
            }
        }
    });
    let good = trajectory_csv(12);
    assert!(Sampled::from_table(&Table::parse(&good, "t").unwrap(), 6).is_ok());
    for (from, to, why) in [
        ("0.01,0.02", "nan,0.02", "NaN position"),
        ("0.01,0.02", "inf,0.02", "infinite position"),
        ("\n0.1,", "\n-5,", "times not increasing"),
    ] {
        let bad = with(&good, from, to);
        let r = Table::parse(&bad, "t").and_then(|t| Sampled::from_table(&t, 6));
        assert!(r.is_err(), "{why}");
    }
}

#[test]
fn power_model_json() {
    let robot = common::irb1200();
    let layout = ParamLayout::new(&robot, true, true);
    let model = PowerModel::new(&robot, layout, false).unwrap();
    let json = serde_json::to_vec_pretty(&model).unwrap();
    assert!(serde_json::from_slice::<PowerModel>(&json).is_ok());
    fuzz("model.json", std::slice::from_ref(&json), cases(800), |b| {
        let _ = serde_json::from_slice::<PowerModel>(b);
    });
    assert!(serde_json::from_slice::<PowerModel>(&json[..json.len() / 2]).is_err());
}
