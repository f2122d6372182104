//! `predict --trajectory` and `predict --scenario`: pricing a plan nobody has run, against
//! the library's `PowerModel::predict` and `sweep`'s prediction of the same cell.

use crate::common;

use std::path::{Path, PathBuf};

use common::{run as powertwin, tmp};
use powertwin::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use powertwin::io::table::Table;
use powertwin::trajectory::sampled::Sampled;

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// An excitation written by `excite` and a model identified from its twin run
/// ([`common::efficiency_model`]).
fn fixture() -> &'static (PathBuf, PathBuf) {
    common::efficiency_model()
}

fn read_model(path: &Path) -> PowerModel {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    serde_json::from_value(v["model"].clone()).unwrap()
}

fn predict_json(args: &[&str]) -> serde_json::Value {
    let (code, out, err) = powertwin(&[&["predict", "--json"], args].concat());
    assert_eq!(code, 0, "{err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

#[test]
fn trajectory_energy_is_the_librarys_prediction() {
    let (traj, model_path) = fixture();
    let robot = common::irb1200();
    let model = read_model(model_path);
    let plan = Sampled::from_table(&Table::read(traj).unwrap(), robot.dof()).unwrap();
    let lib = model
        .predict(&robot, &plan, &[], DATASHEET_EFFICIENCY, 1e-3)
        .unwrap();
    let power_out = tmp("plan_power.csv");
    let v = predict_json(&[
        "--model",
        &s(model_path),
        "--trajectory",
        &s(traj),
        "--power-out",
        &s(&power_out),
    ]);
    let e = v["energy_J"].as_f64().unwrap();
    assert!(
        (e - lib.energy_j).abs() <= 1e-9 * lib.energy_j.abs(),
        "{v} vs {lib:?}"
    );
    let lo_hi = [
        v["interval_J"][0].as_f64().unwrap(),
        v["interval_J"][1].as_f64().unwrap(),
    ];
    assert!(
        (lo_hi[0] - (lib.energy_j - lib.interval_j)).abs() < 1e-9 * e,
        "{v}"
    );
    assert!(
        (lo_hi[1] - (lib.energy_j + lib.interval_j)).abs() < 1e-9 * e,
        "{v}"
    );
    assert!(lib.interval_j > 0.0, "{lib:?}");
    let d = v["duration_s"].as_f64().unwrap();
    assert_eq!(d, lib.duration_s);
    assert!(
        (v["mean_power_W"].as_f64().unwrap() - e / d).abs() < 1e-9 * e,
        "{v}"
    );
    assert_eq!(v["source"].as_str().unwrap(), s(traj));
    // The power along the plan, at the file's samples, integrates to the energy.
    let p = Table::read(&power_out).unwrap();
    let (t, w) = (
        p.column(&["t_s"]).unwrap(),
        p.column(&["P_predicted_W"]).unwrap(),
    );
    let rows = Table::read(traj).unwrap().rows();
    assert_eq!(t.len(), rows);
    let integral: f64 = (1..t.len())
        .map(|k| 0.5 * (w[k] + w[k - 1]) * (t[k] - t[k - 1]))
        .sum();
    assert!((integral - e).abs() < 0.01 * e.abs(), "{integral} vs {e}");
    // Text: one line, the same figures to the printed digit.
    let (code, out, err) = powertwin(&[
        "predict",
        "--model",
        &s(model_path),
        "--trajectory",
        &s(traj),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        out,
        format!(
            "{}: predicted {:.2} ± {:.2} J (95 %), duration {:.3} s, mean power {:.2} W\n",
            s(traj),
            lib.energy_j,
            lib.interval_j,
            lib.duration_s,
            lib.energy_j / lib.duration_s
        )
    );
}

#[test]
fn positions_alone_give_the_same_energy() {
    let (traj, model) = fixture();
    let text = std::fs::read_to_string(traj).unwrap();
    let positions: String = text
        .lines()
        .map(|l| l.split(',').take(7).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    assert!(positions.starts_with("t_s,q1_rad,"), "{positions:.80}");
    assert!(!positions.contains("dq1"));
    let path = tmp("positions.csv");
    std::fs::write(&path, positions).unwrap();
    let full = predict_json(&["--model", &s(model), "--trajectory", &s(traj)]);
    let pos = predict_json(&["--model", &s(model), "--trajectory", &s(&path)]);
    let (a, b) = (
        full["energy_J"].as_f64().unwrap(),
        pos["energy_J"].as_f64().unwrap(),
    );
    assert!((b - a).abs() < 0.005 * a.abs(), "{b} vs {a}");
    assert_ne!(a, b, "the positions-only plan must take its own route");
}

#[test]
fn bad_plans_are_refused_naming_the_file() {
    let (traj, model) = fixture();
    let text = std::fs::read_to_string(traj).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let edit = |name: &str, f: &dyn Fn(usize, Vec<String>) -> Vec<String>| {
        let out: String = lines
            .iter()
            .enumerate()
            .map(|(k, l)| {
                let cells = l.split(',').map(str::to_string).collect();
                (if k == 0 { cells } else { f(k, cells) }).join(",") + "\n"
            })
            .collect();
        let path = tmp(name);
        std::fs::write(&path, out).unwrap();
        path
    };
    // Joint 1 shifted by 4 rad: outside its +-2.97 rad everywhere.
    let outside = edit("outside.csv", &|_, mut c| {
        c[1] = (c[1].parse::<f64>().unwrap() + 4.0).to_string();
        c
    });
    let nan = edit("nan.csv", &|k, mut c| {
        if k == 100 {
            c[2] = "NaN".into();
        }
        c
    });
    let short = tmp("short.csv");
    std::fs::write(&short, format!("{}\n{}\n", lines[0], lines[1])).unwrap();
    for (path, why) in [
        (&outside, "joint 1"),
        (&nan, "row 101"),
        (&short, "at least 2 samples"),
    ] {
        let (code, out, err) =
            powertwin(&["predict", "--model", &s(model), "--trajectory", &s(path)]);
        assert_eq!(code, 1, "{}: {err}", path.display());
        assert!(out.is_empty(), "{out}");
        assert!(err.contains(&s(path)), "{err}");
        assert!(err.contains(why), "{err}");
    }
    // A model of another robot.
    let ur5 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ur5.urdf");
    let (code, _, err) = powertwin(&[
        "predict",
        "--robot",
        &s(&ur5),
        "--model",
        &s(model),
        "--trajectory",
        &s(traj),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(&s(model)) && err.contains("ur5"), "{err}");
    // A plan conflicts with a log; --speed needs a scenario.
    let (code, _, err) = powertwin(&[
        "predict",
        "--model",
        &s(model),
        "--trajectory",
        &s(traj),
        "--log",
        &s(traj),
    ]);
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = powertwin(&[
        "predict",
        "--model",
        &s(model),
        "--trajectory",
        &s(traj),
        "--speed",
        "0.5",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--scenario"), "{err}");
}

#[test]
fn scenario_energy_is_sweeps_prediction() {
    let (_, model) = fixture();
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/pick_and_place.toml");
    let v = predict_json(&[
        "--model",
        &s(model),
        "--scenario",
        &s(&scenario),
        "--speed",
        "0.5",
        "--load",
        "2",
    ]);
    // Without --speed and --load: the sweep speed nearest 0.5 m/s and the heaviest load.
    let default = predict_json(&["--model", &s(model), "--scenario", &s(&scenario)]);
    assert!(
        default["source"]
            .as_str()
            .unwrap()
            .ends_with("at 0.5 m/s, load 4 kg"),
        "{default}"
    );
    let out = tmp("sweep");
    let (code, text, err) = powertwin(&[
        "sweep",
        "--model",
        &s(model),
        "--speeds",
        "0.5",
        "--loads",
        "2",
        "--json",
        "--out",
        &s(&out),
    ]);
    assert_eq!(code, 0, "{err}");
    let sweep: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cell = &sweep["cells"][0];
    // The model's signal decides which of sweep's predictions is its energy.
    let field = match v["power_signal"].as_str().unwrap() {
        "total" => "predicted_J",
        _ => "predicted_grid_J",
    };
    let (e, want) = (
        v["energy_J"].as_f64().unwrap(),
        cell[field].as_f64().unwrap(),
    );
    assert!((e - want).abs() <= 1e-9 * want.abs(), "{v} vs {cell}");
    assert!(
        (v["duration_s"].as_f64().unwrap() - cell["cycle_time_s"].as_f64().unwrap()).abs() < 1e-9
    );
}

/// The 30 held-out plans of the IRB 1200's benchmark, each written as the plan CSV `excite`
/// writes (1 kHz, every column) and priced as `predict --trajectory` prices it, give
/// `validate`'s "from the plan" energies (`PowerModel::predict` on the commanded trajectory at
/// the twin's 1 ms step) to 5e-5 (0.005 %; validate prints errors to 0.001 %) and their 95 %
/// intervals to 3e-3, relative. Resampling a linear move's IK path moves its energy by about
/// 2e-6; a joint coming to rest between the CSV's samples switches its Coulomb gradient, and
/// its gear friction `|tau dq|` in the other friction structure's energy, at a slightly
/// different time: that structure's energy moves more than the plan's own resampling does,
/// and the prediction is the mean of the two structures'. The interval holds half their difference, and 3e-3 of it
/// is a few hundred-thousandths of the energy.
#[test]
fn heldout_plans_from_csv_are_priced_as_validate_prices_them() {
    use powertwin::identification::plan::{price, read_plan};
    use powertwin::trajectory::table::trajectory_csv;
    use powertwin::validation::heldout::{HeldoutOptions, motions};
    let (_, model_path) = fixture();
    let model = read_model(model_path);
    let robot = common::irb1200();
    let opts = HeldoutOptions::irb1200(30);
    let motions = motions(&robot, &opts).unwrap();
    assert_eq!(motions.len(), 30);
    for (k, m) in motions.iter().enumerate() {
        let path = tmp(&format!("heldout_{k:02}.csv"));
        std::fs::write(
            &path,
            trajectory_csv(m.trajectory.as_ref(), 1000.0).unwrap(),
        )
        .unwrap();
        let plan = read_plan(&robot, &path).unwrap();
        let t: Vec<f64> = plan.sample_times().to_vec();
        let eff = opts.baseline_efficiency;
        let priced = price(&model, &robot, &plan, &m.events, eff, &t).unwrap();
        let validate = model
            .predict(&robot, m.trajectory.as_ref(), &m.events, eff, 1e-3)
            .unwrap();
        let (a, b) = (&priced.prediction, &validate);
        let rel = |x: f64, y: f64| (x - y).abs() / y.abs().max(1e-9);
        assert!(
            rel(a.energy_j, b.energy_j) < 5e-5 && rel(a.interval_j, b.interval_j) < 3e-3,
            "motion {} ({}): plan CSV {} +- {} J, validate {} +- {} J",
            k + 1,
            m.kind,
            a.energy_j,
            a.interval_j,
            b.energy_j,
            b.interval_j
        );
    }
}
