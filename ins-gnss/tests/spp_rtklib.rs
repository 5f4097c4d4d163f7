//! `ins-gnss spp` against RTKLIB 2.4.3's single point (`rnx2rtkp`) on the two shipped
//! stations, in three configurations (the references and the script that made them are in
//! `data/rinex-rtklib/rtklib/`).

use gnss::spp::{Ionosphere, Troposphere};
use gnss::{SppOptions, System};
use ins_gnss::spp::{compare, read_pos, scatter, solve_file};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/rinex-rtklib").join(name)
}

/// (reference file suffix, options matching RTKLIB's, largest 3D RMS difference, m).
fn cases() -> Vec<(&'static str, SppOptions, f64)> {
    vec![
        // `rnx2rtkp -p 0`: no atmosphere; measured 0.006 m on both stations
        ("default", SppOptions::rtklib_default(), 0.02),
        // broadcast ionosphere and Saastamoinen: measured 0.009 m
        ("klobuchar-saas", SppOptions { max_exclusions: 0, ..SppOptions::default() }, 0.03),
        // iono-free P1/P2 and Saastamoinen: measured 0.174 / 0.145 m (RTKLIB weights
        // by 1/sin(el), this crate by 1/sin²(el); the iono-free noise makes that visible)
        (
            "ionofree-saas",
            SppOptions {
                ionosphere: Ionosphere::IonoFree,
                troposphere: Troposphere::Saastamoinen,
                max_exclusions: 0,
                ..SppOptions::default()
            },
            0.25,
        ),
    ]
}

#[test]
fn single_point_agrees_with_rtklib_on_both_stations() {
    for station in ["0759", "3040"] {
        let obs = data(&format!("{station}0920.05o.zst"));
        let nav = data(&format!("{station}0920.05n.zst"));
        for (name, opt, bound) in cases() {
            let run = solve_file(&obs, &[nav.as_path()], &opt).unwrap();
            let theirs = read_pos(&data(&format!("rtklib/spp{station}-{name}.pos.zst"))).unwrap();
            let ours = run.positions();
            let (n, rms, mean) = compare(&ours, &theirs);
            let (h_ours, v_ours, _) = scatter(&ours.iter().map(|p| p.1).collect::<Vec<_>>());
            let (h_theirs, v_theirs, _) = scatter(&theirs.iter().map(|p| p.1).collect::<Vec<_>>());
            eprintln!(
                "{station} {name}: {n} common of {}/{}, 3D RMS {rms:.3} m, mean NED {:.3} {:.3} {:.3}; \
                 scatter ours {h_ours:.3}/{v_ours:.3}, RTKLIB {h_theirs:.3}/{v_theirs:.3} m",
                ours.len(),
                theirs.len(),
                mean.x,
                mean.y,
                mean.z
            );
            // the same epochs solved (RTKLIB refuses the same 5 on GDOP)
            assert_eq!(n, theirs.len(), "{station} {name}");
            assert_eq!(ours.len(), theirs.len(), "{station} {name}");
            assert!(rms < bound, "{station} {name}: {rms} m");
            // horizontal scatter about the station's mean no larger than RTKLIB's
            assert!(h_ours <= h_theirs + 0.005, "{station} {name}: {h_ours} > {h_theirs}");
        }
    }
}

/// Niell's mapping against 1/sin(el), one change on real data: the two stations at a 5°
/// and a 15° mask with Klobuchar. 1/sin(el) overstates the low satellites' delay (0.5 m at
/// 10°, 3 m at 5°), which pulls the solved height down as the mask admits them; Niell's
/// mapping shrinks that pull. Measured (`ins-gnss spp --tropo saastamoinen|niell --mask
/// 5|15`): mean heights +0.11 m at 15° on both stations, +0.72 / +0.93 m at 5°; the height's
/// drop from a 15° to a 5° mask 1.89 → 1.29 m and 2.24 → 1.42 m.
#[test]
fn niell_mapping_lifts_the_height_by_what_the_low_satellites_carry() {
    for station in ["0759", "3040"] {
        let obs = data(&format!("{station}0920.05o.zst"));
        let nav = data(&format!("{station}0920.05n.zst"));
        let solve = |troposphere, mask: f64| {
            let opt = SppOptions {
                troposphere,
                elevation_mask: mask.to_radians(),
                ..SppOptions::default()
            };
            let run = solve_file(&obs, &[nav.as_path()], &opt).unwrap();
            let pts: Vec<Vector3<f64>> = run.solutions.iter().map(|s| s.pos).collect();
            let (h, v, mean) = scatter(&pts);
            let (_, _, height) = ins_gnss_core::earth::ecef_to_geodetic(&mean);
            (h, v, mean, height)
        };
        let flat15 = solve(Troposphere::Saastamoinen, 15.0);
        let niell15 = solve(Troposphere::Niell, 15.0);
        let flat5 = solve(Troposphere::Saastamoinen, 5.0);
        let niell5 = solve(Troposphere::Niell, 5.0);
        let lift15 = niell15.3 - flat15.3;
        let lift5 = niell5.3 - flat5.3;
        eprintln!(
            "{station}: Niell − 1/sin height {lift15:.3} m (15°), {lift5:.3} m (5°); drop 15°→5° \
             {:.3} (1/sin) {:.3} (Niell) m; horizontal scatter at 5° {:.3} / {:.3} m",
            flat15.3 - flat5.3,
            niell15.3 - niell5.3,
            flat5.0,
            niell5.0
        );
        // the lift grows with the lowest elevation admitted, as the mappings part below 15°
        assert!(lift15 > 0.05 && lift15 < 0.2, "{station}: {lift15}");
        assert!(lift5 > 0.5 && lift5 < 1.2, "{station}: {lift5}");
        // the height depends less on the mask with Niell's mapping
        assert!((niell15.3 - niell5.3).abs() < (flat15.3 - flat5.3).abs() - 0.3, "{station}");
        // horizontally the satellites' delays nearly cancel around the sky: the mean moves by
        // a fifth of the height's lift (measured 0.13 and 0.21 m)
        let (lat, lon, _) = ins_gnss_core::earth::ecef_to_geodetic(&flat5.2);
        let d = ins_gnss_core::earth::ecef_to_ned_rotation(lat, lon) * (niell5.2 - flat5.2);
        eprintln!("{station}: horizontal mean moved {:.3} m at 5°", d.x.hypot(d.y));
        assert!(d.x.hypot(d.y) < 0.3, "{station}: {d}");
    }
}

/// GPS and BeiDou from a u-blox log (`data/ubx-sim/bds.ubx.zst`: BeiDou D1 ephemerides
/// from its RXM-SFRBX, no navigation file) against RTKLIB's single point of its `convbin`
/// RINEX with both systems (`bds-rtklib.conf`: no mask, Klobuchar, Saastamoinen; the same
/// options here, no RAIM). Measured: 201 of 201 epochs with 9–10 GPS, 3 BeiDou MEO and 3
/// BeiDou GEO satellites, 3D RMS 0.049 m; our GPS-only solution of the same log sits
/// metres from it, so the BeiDou satellites (with a clock of their own, the GEOs' orbits
/// from D2) are what agrees.
#[test]
fn gps_and_beidou_from_a_ubx_log_agree_with_rtklib() {
    let opt = SppOptions { elevation_mask: 0.0, max_exclusions: 0, ..SppOptions::default() };
    let run = solve_file(&repo("ubx-sim/bds.ubx.zst"), &[], &opt).unwrap();
    let theirs = read_pos(&repo("ubx-sim/bds-rtklib.pos.zst")).unwrap();
    let ours = run.positions();
    let (n, rms, _) = compare(&ours, &theirs);
    eprintln!("GPS + BeiDou from UBX: {n} of {} epochs, 3D RMS {rms:.3} m", theirs.len());
    assert_eq!((n, theirs.len()), (201, 201));
    assert!(rms < 0.1, "{rms}");
    // every epoch used the 6 BeiDou satellites, 3 of them GEO, with a BeiDou clock
    for s in &run.solutions {
        let bds = s.used.iter().filter(|u| u.0.sys == System::BeiDou).count();
        let geo = s.used.iter().filter(|u| u.0.beidou_geo()).count();
        assert_eq!((bds, geo), (6, 3), "{}", s.time);
        assert!(s.clocks.iter().any(|c| c.0 == System::BeiDou));
    }
    // and without them the solution is another one
    let gps = SppOptions { systems: vec![System::Gps], ..opt };
    let run = solve_file(&repo("ubx-sim/bds.ubx.zst"), &[], &gps).unwrap();
    let ours = run.positions();
    let (_, rms_gps, _) = compare(&ours, &theirs);
    eprintln!("GPS alone against RTKLIB's GPS + BeiDou: 3D RMS {rms_gps:.3} m");
    assert!(rms_gps > 0.3, "{rms_gps}");
}

#[test]
fn the_program_writes_a_pos_that_reads_back() {
    let dir = std::env::temp_dir().join(format!("spp-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("spp0759.pos");
    let obs = data("07590920.05o.zst");
    let nav = data("07590920.05n.zst");
    ins_gnss::spp::run(&obs, &[nav.as_path()], Some(&out), &SppOptions::rtklib_default(), None)
        .unwrap();
    let back = read_pos(&out).unwrap();
    let theirs = read_pos(&data("rtklib/spp0759-default.pos.zst")).unwrap();
    let (n, rms, _) = compare(&back, &theirs);
    assert_eq!(n, 115);
    assert!(rms < 0.02, "{rms}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("% pos mode  : single point (ionosphere Off, troposphere Off"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn repo(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data").join(name)
}

/// A u-blox log solves alone (its GPS subframes give the ephemerides and the ionosphere)
/// as its observations do with the navigation file the log was made from (measured: 1.4 mm
/// 3D RMS, the LNAV message's resolution).
#[test]
fn a_ubx_log_solves_as_its_observations_with_the_source_navigation() {
    let opt = SppOptions::default();
    let ubx = solve_file(&repo("ubx-sim/sim.ubx.zst"), &[], &opt).unwrap();
    let nav = repo("rinex-rtklib/07590920.05n.zst");
    let rinex = solve_file(&repo("ubx-sim/sim.obs.zst"), &[nav.as_path()], &opt).unwrap();
    assert_eq!(ubx.solutions.len(), 201);
    let a = ubx.positions();
    let b = rinex.positions();
    let (n, rms, _) = compare(&a, &b);
    assert_eq!(n, 201);
    assert!(rms < 0.01, "{rms}");
}

/// Ephemerides of another week than the observations (here convbin's: it resolves the
/// 10-bit week of a 2005 log against today's date) are refused, naming the file and both
/// weeks, instead of giving "too few satellites" at every epoch.
#[test]
fn ephemerides_of_another_week_are_refused() {
    let nav = repo("ubx-sim/sim.nav.zst");
    let err = solve_file(&repo("ubx-sim/sim.obs.zst"), &[nav.as_path()], &SppOptions::default())
        .unwrap_err();
    let m = err.to_string();
    assert!(
        m.contains("sim.nav.zst") && m.contains("weeks 2340") && m.contains("week 1316"),
        "{m}"
    );
    // a file that mixes systems, checked system by system: convbin's Galileo records are
    // of the log's week (GST's 12-bit week), its GPS ones are not
    let nav = repo("ubx-sim/gal.nav.zst");
    let err = solve_file(&repo("ubx-sim/gal.obs.zst"), &[nav.as_path()], &SppOptions::default())
        .unwrap_err();
    let m = err.to_string();
    assert!(m.contains("GPS ephemerides of") && m.contains("weeks 2340"), "{m}");
}
