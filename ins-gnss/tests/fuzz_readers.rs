//! Fuzzing the readers with proptest: random bytes and random near-valid lines must give
//! records or typed errors, never a panic. (The target for the project's fuzzing; run
//! with more cases via `PROPTEST_CASES=100000 cargo test -p ins-gnss --test main fuzz_readers::`.)

use std::io::Cursor;
use std::path::Path;

use ins_gnss_io::{BadLinePolicy, GnssReader, ImuFormat, ImuReader, NavReader};
use proptest::prelude::*;

fn drain_all(bytes: &[u8]) {
    for policy in [BadLinePolicy::Error, BadLinePolicy::Skip] {
        for format in [ImuFormat::Increments, ImuFormat::Rates] {
            let mut r = ImuReader::new(
                Cursor::new(bytes.to_vec()),
                Path::new("f"),
                format,
                100.0,
                5.0,
                policy,
            );
            while let Ok(Some(_)) = r.next_sample() {}
        }
        let mut g = GnssReader::new(Cursor::new(bytes.to_vec()), Path::new("f"), policy);
        while let Ok(Some(_)) = g.next_epoch() {}
    }
    let mut n = NavReader::new(Cursor::new(bytes.to_vec()), Path::new("f"));
    while let Ok(Some(_)) = n.next_record() {}
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = toml::from_str::<ins_gnss::config::Config>(text);
    }
}

fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        (-1e6f64..1e6).prop_map(|v| v.to_string()),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("-".to_string()),
        Just("1e400".to_string()),
        Just(",".to_string()),
        "[a-z#%]{1,3}",
        Just(String::new()),
    ]
}

fn line() -> impl Strategy<Value = String> {
    prop::collection::vec(token(), 0..15).prop_map(|t| t.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        drain_all(&bytes);
    }

    #[test]
    fn random_lines_never_panic(lines in prop::collection::vec(line(), 0..40)) {
        drain_all(lines.join("\n").as_bytes());
    }
}
