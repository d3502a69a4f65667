//! Test support: checks that a stats struct's `+=` merges every field.
//!
//! [`assert_merges_every_field`] fills every numeric leaf of a template (as serialised by
//! serde: nested structs, arrays, Vecs, histograms) with 1 in one copy and 2 in another, then
//! merges them both ways. A merged field gives the same value either way (1 + 2, max, min); a
//! field left out of the merge keeps the left side's value, so `a += b` and `b += a` disagree
//! there, and the check names its path.

use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::ops::AddAssign;

fn fill(v: &mut Value, x: u64) {
    match v {
        Value::Number(n) => {
            *v = if n.is_f64() {
                Value::from(x as f64)
            } else {
                Value::from(x)
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|e| fill(e, x)),
        Value::Object(o) => o.values_mut().for_each(|e| fill(e, x)),
        _ => {}
    }
}

fn diff(a: &Value, b: &Value, path: &str, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                diff(p, q, &format!("{path}[{i}]"), out);
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            for (k, p) in x {
                match y.get(k) {
                    Some(q) => diff(p, q, &format!("{path}.{k}"), out),
                    None => out.push(format!("{path}.{k}")),
                }
            }
        }
        _ if a != b => out.push(format!("{path}: {a} vs {b}")),
        _ => {}
    }
}

/// Panics, naming the fields, if `a += &b` and `b += &a` differ anywhere for copies of
/// `template` whose numeric leaves are all 1 (in `a`) and all 2 (in `b`). Vecs in the
/// template should be non-empty so that their elements are checked too.
pub fn assert_merges_every_field<T>(template: &T)
where
    T: Serialize + DeserializeOwned + for<'a> AddAssign<&'a T>,
{
    let mut base = serde_json::to_value(template).expect("stats serialise");
    let make = |base: &mut Value, x: u64| -> T {
        fill(base, x);
        serde_json::from_value(base.clone()).expect("filled stats deserialise")
    };
    let (mut ab, b) = (make(&mut base, 1), make(&mut base, 2));
    let (mut ba, a) = (make(&mut base, 2), make(&mut base, 1));
    ab += &b;
    ba += &a;
    let (x, y) = (
        serde_json::to_value(&ab).expect("stats serialise"),
        serde_json::to_value(&ba).expect("stats serialise"),
    );
    let mut bad = Vec::new();
    diff(&x, &y, "", &mut bad);
    assert!(
        bad.is_empty(),
        "fields not merged by +=: {}",
        bad.join(", ")
    );
}
