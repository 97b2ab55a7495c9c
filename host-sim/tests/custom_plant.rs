//! `[plant] model = "custom"`: Example 1 written as expressions gives the summary of the
//! built-in model, and bad expressions are exit 2 naming the key and the column.
//!
//! A constant times a whole power of a variable, `0.8*x1^3`, is evaluated as `((0.8*x1)*x1)*x1`,
//! the built-in model's order, so the shipped file gives the built-in summary to the bit. Another
//! order, `x1^3*0.8` = `(x1*x1*x1)*0.8`, differs in the last place now and then, which the f32
//! controllers and the hysteresis quantizer turn into a few different quantizer switchings and so
//! into adaptive estimates that end up to 2e-3 apart: every other figure agrees to 6 digits.

mod common;

use host_sim::{run::simulate, scenario};
use serde_json::Value;

/// Every number of `a` and `b` agrees to `digits` significant digits; everything else is equal.
fn assert_close(path: &str, a: &Value, b: &Value, digits: i32) {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            let scale = x.abs().max(y.abs());
            assert!(
                (x - y).abs() <= 0.5 * 10f64.powi(1 - digits) * scale,
                "{path}: {x} vs {y} differ in the first {digits} significant digits"
            );
        }
        (Value::Object(x), Value::Object(y)) => {
            let keys = |o: &serde_json::Map<String, Value>| o.keys().cloned().collect::<Vec<_>>();
            assert_eq!(keys(x), keys(y), "{path}: keys");
            for (k, v) in x {
                assert_close(&format!("{path}.{k}"), v, &y[k], digits);
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{path}: lengths");
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                assert_close(&format!("{path}[{i}]"), v, w, digits);
            }
        }
        _ => assert_eq!(a, b, "{path}"),
    }
}

fn summary(file: &str, sets: &[String]) -> Value {
    let setup = scenario::load(&common::scenario_path(file), sets).expect("scenario");
    let mut v = serde_json::to_value(simulate(&setup).expect("run")).expect("json");
    for k in ["scenario", "model"] {
        v.as_object_mut().map(|o| o.remove(k));
    }
    v
}

/// The fields that follow a few quantizer switchings: the count itself and the final
/// adaptive estimates.
const SWITCHING: [&str; 4] = ["quantizer_changes", "final_mu", "final_xi", "final_lambda"];

fn without_switching(mut v: Value) -> Value {
    for a in v["agents"].as_array_mut().into_iter().flatten() {
        for k in SWITCHING {
            a.as_object_mut().map(|o| o.remove(k));
        }
    }
    v
}

#[test]
fn custom_example1_equals_the_built_in_model() {
    let built_in = summary("example1.toml", &[]);
    assert_eq!(built_in["diverged"], false);
    // The shipped file, `0.8*x1^3`: the same summary, to the bit.
    assert_eq!(built_in, summary("example1-custom.toml", &[]));
    // Another rounding order: every figure to 6 significant digits but those of `SWITCHING`,
    // which agree to 2.
    let other_order = [r#"plant.dynamics=["x2 + x1^3*0.8", "u - 2*x1^2 + x2^3 + cos(t)"]"#.into()];
    let custom = summary("example1-custom.toml", &other_order);
    assert_close(
        "",
        &without_switching(built_in.clone()),
        &without_switching(custom.clone()),
        6,
    );
    assert_close("", &built_in, &custom, 2);
}

#[test]
fn bad_expressions_name_the_key_and_the_column() {
    let path = common::scenario_path("example1-custom.toml");
    for (set, key, at) in [
        (
            r#"plant.dynamics=["x2 + 0.8*x1^3", "u - 2*x1^2 + (x2^3"]"#,
            "plant.dynamics[2]",
            "column 14",
        ),
        (
            r#"plant.dynamics=["x2 + 0.8*y1^3", "u"]"#,
            "plant.dynamics[1]",
            "`y1` at column 10",
        ),
        (
            r#"plant.dynamics=["x2 +* x1", "u"]"#,
            "plant.dynamics[1]",
            "column 5",
        ),
    ] {
        let out = common::bin()
            .args([
                "check".as_ref(),
                path.as_os_str(),
                "--set".as_ref(),
                set.as_ref(),
            ])
            .output()
            .expect("host-sim");
        common::assert_invalid(&out, key);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(at), "{set}: {err}");
    }
}
