//! The Python package `uavswarm` (python/): installed from the checkout with one `pip install`
//! (into a folder of the test's own), then held to PettingZoo's `parallel_api_test` and
//! `parallel_seed_test` and Gymnasium's `check_env` on the real swarm, with the same seed giving
//! the same episode, bad actions refused by name, nothing left running after a bad action or a
//! Python killed outright, and `load_run` (run.mcap through Foxglove's `mcap` reader).

mod common;

use std::process::Command;

#[test]
fn the_python_package_installs_and_passes_pettingzoo_and_gymnasium_checks_on_the_real_swarm() {
    let dir = tempfile::tempdir().expect("tempdir");
    let site = dir.path().join("site");
    let install = Command::new(common::python())
        .args([
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--disable-pip-version-check",
            "--target",
        ])
        .arg(&site)
        .arg(common::root().join("python"))
        .output()
        .expect("pip");
    assert!(install.status.success(), "pip install ./python: {}", String::from_utf8_lossy(&install.stderr));
    assert!(site.join("uavswarm/env.py").exists(), "installed where asked");

    let script = common::root().join("tests/tests/python/env_checks.py");
    let mut c = Command::new(common::python());
    c.arg(script).arg(dir.path().join("runs")).env("PYTHONPATH", &site).env("SWARM_BIN", common::SWARM);
    let o = common::output_within(&mut c, std::time::Duration::from_secs(900));
    assert!(
        o.status.success(),
        "the checks failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let text = String::from_utf8_lossy(&o.stdout);
    let seen: serde_json::Value = serde_json::from_str(text.lines().last().expect("a line")).expect("json");
    assert_eq!(seen["killed_python_left"], 0);
    println!("uavswarm on the real swarm: {seen}");
}
