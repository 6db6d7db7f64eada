//! The output layer: staging, failure, identity of inputs.

use super::*;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fs-output-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn nothing_exists_until_finish_and_a_failure_leaves_nothing() {
    let d = scratch("stage");
    let (a, b) = (d.join("a.csv"), d.join("b.csv"));
    let mut plan = Plan::new();
    plan.write(&Dest::File(a.clone()), |w| Ok(w.write_all(b"one\n")?), None)
        .unwrap();
    // The first output is complete but not in place; only its temporary file exists.
    assert!(!a.exists());
    assert_eq!(names(&d).len(), 1);
    let failed = plan.write(
        &Dest::File(b.clone()),
        |w| {
            w.write_all(b"half")?;
            anyhow::bail!("the model failed")
        },
        None,
    );
    assert!(failed.is_err());
    drop(plan);
    assert!(names(&d).is_empty(), "{:?}", names(&d));
    // A plan that finishes puts both in place, with their whole content.
    let mut plan = Plan::new();
    plan.write(&Dest::File(a.clone()), |w| Ok(w.write_all(b"one\n")?), None)
        .unwrap();
    plan.write(&Dest::File(b.clone()), |w| Ok(w.write_all(b"two\n")?), None)
        .unwrap();
    plan.finish().unwrap();
    assert_eq!(names(&d), ["a.csv", "b.csv"]);
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "two\n");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn an_input_is_recognised_by_any_name() {
    let d = scratch("ident");
    let f = d.join("in.csv");
    std::fs::write(&f, "x").unwrap();
    std::os::unix::fs::symlink(&f, d.join("sym.csv")).unwrap();
    for out in [
        d.join("./in.csv"),
        d.join("sym.csv"),
        d.join("sub/../in.csv"),
    ] {
        std::fs::create_dir_all(d.join("sub")).unwrap();
        let mut plan = Plan::new();
        plan.input("--in", &f);
        plan.output("--out", Some(&out), Kind::Table);
        let e = plan.check().unwrap_err().to_string();
        assert!(e.contains("refusing to overwrite an input"), "{out:?}: {e}");
    }
    // A new file beside it is fine.
    let mut plan = Plan::new();
    plan.input("--in", &f);
    plan.output("--out", Some(&d.join("new.csv")), Kind::Table);
    plan.check().unwrap();
    std::fs::remove_dir_all(&d).ok();
}
