//! Fuzzing the OTB ground-truth parser (issue 15): arbitrary text never panics, valid
//! files written here round-trip exactly, and one bad line is an error naming it.

use proptest::prelude::*;
use tracking::TrackingError;
use tracking::otb::parse_groundtruth;

/// Finite corners, non-negative sizes: the boxes a valid file holds.
fn boxes() -> impl Strategy<Value = Vec<[f64; 4]>> {
    let coord = -1e6f64..1e6;
    let size = 0f64..1e6;
    prop::collection::vec((coord.clone(), coord, size.clone(), size), 1..20)
        .prop_map(|v| v.into_iter().map(|(x, y, w, h)| [x, y, w, h]).collect())
}

/// Each box on a line, fields joined by `sep`; Rust's `{}` for f64 prints the
/// shortest text that parses back to the same value.
fn file(boxes: &[[f64; 4]], sep: &str, newline: &str) -> String {
    boxes
        .iter()
        .map(|b| b.map(|v| v.to_string()).join(sep))
        .collect::<Vec<_>>()
        .join(newline)
}

fn line_of(err: TrackingError) -> usize {
    match err {
        TrackingError::Parse { line, .. } => line,
        other => panic!("expected a parse error, got {other:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(parsed) = parse_groundtruth(&text, "g") {
            for b in parsed {
                prop_assert!(b.to_array().iter().all(|v| v.is_finite()));
                prop_assert!(b.to_array()[2] >= 0.0 && b.to_array()[3] >= 0.0);
            }
        }
    }

    #[test]
    fn arbitrary_unicode_text_never_panics(text in "\\PC{0,200}") {
        let _ = parse_groundtruth(&text, "g");
    }

    #[test]
    fn valid_files_round_trip(
        b in boxes(),
        sep in prop::sample::select(vec!["\t", ",", " ", ", ", " \t"]),
        newline in prop::sample::select(vec!["\n", "\r\n"]),
        trailing in prop::sample::select(vec!["", "\n", "\n\n", "\r\n  \n"]),
    ) {
        let text = file(&b, sep, newline) + trailing;
        let parsed = parse_groundtruth(&text, "g").unwrap();
        prop_assert_eq!(parsed.len(), b.len());
        for (got, want) in parsed.iter().zip(&b) {
            prop_assert_eq!(got.to_array(), [want[0] - 1.0, want[1] - 1.0, want[2], want[3]]);
        }
    }

    #[test]
    fn one_bad_line_is_named(
        b in boxes(),
        at in any::<prop::sample::Index>(),
        bad in prop::sample::select(vec![
            "1 2 3", "1 2 3 4 5", "1 2 x 4", "1 2 NaN 4", "1 2 inf 4", "1 2 -3 4", "", "1 2 3 1e999",
        ]),
    ) {
        let k = at.index(b.len());
        let mut lines: Vec<String> = b.iter().map(|x| x.map(|v| v.to_string()).join("\t")).collect();
        lines[k] = bad.to_string();
        lines.push("0 0 1 1".into()); // so that a blank line k is inside the file
        let err = parse_groundtruth(&lines.join("\n"), "g").unwrap_err();
        prop_assert_eq!(line_of(err), k + 1);
    }
}
