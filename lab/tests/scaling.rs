//! The scaling mode at its smoke sizes, on impact3d alone, with the counting allocator installed
//! as the lab binary installs it: one row per engine, scene and size, positive times and memory,
//! the three files written and the CSV read back as written; and the report of a run on two
//! thread counts pairs each size's rows into impact3d's speed-up.

use impact3d_lab::Mode;
use impact3d_lab::alloc;
use impact3d_lab::scaling::{self, CSV_HEADER, Family, Plan};

#[global_allocator]
static ALLOCATOR: alloc::Counting = alloc::Counting;

#[test]
fn smoke_scaling_writes_one_row_per_engine_and_size() {
    assert!(alloc::installed());
    let plan = Plan::for_mode(Mode::Smoke);
    let rows = scaling::run(&plan, false, |_, _| {});
    let expected = plan.flight.len() + plan.pour.len();
    assert_eq!(rows.len(), expected);
    for (family, sizes) in [(Family::Flight, &plan.flight), (Family::Pour, &plan.pour)] {
        let ns: Vec<usize> = rows
            .iter()
            .filter(|r| r.family == family)
            .map(|r| r.n)
            .collect();
        assert_eq!(&ns, sizes, "{family:?}");
    }
    for r in &rows {
        assert_eq!(r.engine, "impact3d");
        assert!(r.ms_per_step > 0.0 && r.us_per_body() > 0.0, "{r:?}");
        assert!(
            r.bytes_per_body > 0.0,
            "a world of bodies holds memory: {r:?}"
        );
        assert!(
            r.allocs_per_step.is_finite() && r.allocs_per_step >= 0.0,
            "{r:?}"
        );
        assert!(r.max_speed.is_finite(), "{r:?}");
        match r.family {
            Family::Flight => assert_eq!(r.neighbours, 0.0, "no contact in free flight: {r:?}"),
            // One layer at the smoke sizes: it may land without a sphere touching another.
            Family::Pour => assert!(r.neighbours >= 0.0, "{r:?}"),
        }
        assert_eq!(r.steps, plan.steps(r.family));
        assert_eq!(r.warm_up, plan.warm_up(r.family, r.n));
    }
    // The pour's warm-up covers the top layer's fall.
    assert!(plan.warm_up(Family::Pour, 200) > 30);
    let ratios = scaling::ratios(&rows);
    assert_eq!(ratios.len(), 2);
    assert!(ratios.iter().all(|(_, _, r)| r.is_finite() && *r > 0.0));

    let out = std::env::temp_dir().join(format!("impact3d-lab-scaling-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    scaling::write(&out, &plan, &rows, "test", true).expect("the files are written");
    let csv = std::fs::read_to_string(out.join("scaling.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    let data: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(data.len(), expected);
    for row in &data {
        assert_eq!(row.len(), CSV_HEADER.split(',').count(), "{row:?}");
        for k in [6, 8, 9] {
            assert!(row[k].parse::<f64>().unwrap() > 0.0, "{row:?}");
        }
    }
    let md = std::fs::read_to_string(out.join("scaling.md")).unwrap();
    assert!(
        md.contains("| flight | impact3d | 1 | 100 |")
            && md.contains("| pour | impact3d | 1 | 200 |")
    );
    assert!(md.contains("One thread.") && !md.contains("speed-up"));
    let svg = std::fs::read_to_string(out.join("scaling.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("us per body"));
    // Read back, every row is the row written (the CSV's floats print exactly: Rust's
    // shortest round-trip form).
    let back = scaling::read_csv(&csv).expect("the CSV reads back");
    assert_eq!(back, rows);
    assert!(md.contains("under 1.3") && md.contains("global allocator"));
    let usual = impact3d::prelude::SolverConfig::default();
    assert!(md.contains(&format!(
        "({:?}, {} substeps x {} iteration(s))",
        usual.method, usual.substeps, usual.iterations
    )));
    assert!(md.contains(&format!("ran {} time(s)", plan.rounds)));
    std::fs::remove_dir_all(&out).unwrap();

    // The same rows as if also run on two threads at a third of the time: each impact3d row
    // on two threads pairs with its one-thread row, speed-up 3.
    let mut both = rows.clone();
    both.extend(rows.iter().map(|r| scaling::ScaleRow {
        threads: 2,
        ms_per_step: r.ms_per_step / 3.0,
        ..r.clone()
    }));
    let pairs = scaling::speed_ups(&both);
    assert_eq!(pairs.len(), rows.len());
    for (one, two) in &pairs {
        assert_eq!((one.threads, two.threads), (1, 2));
        assert_eq!((one.family, one.n), (two.family, two.n));
        assert!((one.ms_per_step / two.ms_per_step - 3.0).abs() < 1e-9);
    }
    let md = scaling::table(&plan, &both, "test", true);
    assert!(
        md.contains("| flight | 100 | 2 |") && md.contains("| 3.00 |"),
        "{md}"
    );
    assert!(md.contains("impact3d on 1, 2 thread(s)"));
    let ratios = scaling::ratios(&both);
    assert!(ratios.iter().any(|(_, label, _)| label == "impact3d x2"));
}
