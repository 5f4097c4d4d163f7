//! The ROS reader on robot_localization's Husky bag (`data/ros-husky/test1.bag`), its MCAP
//! copies, and the two encodings' layouts.

use super::*;

fn bag() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ros-husky/test1.bag")
}

fn all(stamps: Stamps) -> Selection {
    Selection { use_odometry: true, stamps, ..Default::default() }
}

const KEYS: [&str; 3] = ["data.ros.imu_topic", "data.ros.fix_topic", "data.ros.odometry_topic"];

#[test]
fn the_husky_bag_reads_by_type() {
    let r = Recording::read(&bag(), &all(Stamps::Header), KEYS).unwrap();
    assert_eq!(r.container, Container::Bag);
    assert_eq!(r.imu_topic, ("/imu/data".to_string(), "imu_link".to_string()));
    assert_eq!(r.fix_topic, ("/fix".to_string(), "/gps".to_string()));
    assert_eq!(
        r.odometry_topic,
        Some(("/husky_velocity_controller/odom".to_string(), "base_link".to_string()))
    );
    assert_eq!((r.imu.len(), r.fixes.len(), r.odometry.len()), (11_865, 989, 3_952));
    let counts: usize = r.topics.iter().map(|t| t.messages).sum();
    assert_eq!(counts, 11_865 + 989 + 3_952);
    // gravity's reaction on the sensor's y axis (the IMU is mounted on its side)
    let f = r.imu[0].f;
    assert!(f[1] > 9.0 && f[0].abs() < 1.0 && f[2].abs() < 1.0, "{f:?}");
    // the first fix: 42.3758° N, 71.1474° W, σ 0.9 m horizontally
    let x = &r.fixes[0];
    assert!((x.position[0] - 42.375812).abs() < 1e-6 && (x.position[1] + 71.147395).abs() < 1e-6);
    assert!((x.var_enu[0] - 0.81).abs() < 1e-12 && x.covariance_type == 1 && x.status == 1);
    // 30 Hz, and covariances given
    let rate = r.imu_rate().unwrap();
    assert!((rate - 30.0).abs() < 1.0, "{rate}");
    let (w, a) = r.imu_sigma().unwrap();
    assert!((w[0] - 0.02).abs() < 1e-9 && (a[0] - 0.098).abs() < 1e-9, "{w:?} {a:?}");
    // sorted by stamp, and the header and receive stamps differ by the transport delay
    assert!(r.imu.windows(2).all(|w| w[1].t >= w[0].t));
    let recv = Recording::read(&bag(), &all(Stamps::Receive), KEYS).unwrap();
    let lag = recv.imu[0].t - r.imu[0].t;
    assert!(lag > 0.0 && lag < 0.1, "{lag}");
}

#[test]
fn rows_are_the_formats_rows_in_gpst() {
    let r = Recording::read(&bag(), &all(Stamps::Header), KEYS).unwrap();
    let (rows, width, longest) = r.imu_rows();
    assert_eq!((width, rows.len()), (8, 8 * 11_865));
    // 2015-05-21 19:11:37.989 UTC (`date -u -d @1432235497.989`) is a Thursday: 4 days
    // + 19:11:37.989 into the GPS week, + 16 leap seconds (17 from 2015-07-01)
    let t0 = rows[0];
    let expected = 4.0 * 86_400.0 + 19.0 * 3600.0 + 11.0 * 60.0 + 37.989 + 16.0;
    assert!((t0 - expected).abs() < 0.01, "{t0} vs {expected}");
    // the odometer column lies between the odometry speeds around each sample
    assert!(longest > 0.05 && longest < 0.5, "{longest}");
    let speeds: Vec<f64> = rows.chunks(8).map(|c| c[7]).collect();
    let top = r.odometry.iter().map(|o| o.speed).fold(f64::MIN, f64::max);
    assert!(speeds.iter().all(|s| s.is_finite() && *s <= top + 1e-12));
    // σ N E D from the ENU covariance as it is
    let mut q = QualityFactors::default();
    let (g, dropped) = r.fix_rows(&q, None, "gnss.position_std").unwrap();
    assert_eq!((g.len() / 7, dropped), (989, 0));
    assert!((g[4] - 0.9).abs() < 1e-12 && (g[6] - 1.8).abs() < 1e-12);
    // every fix of the bag is SBAS (status 1): dropping `sbas` leaves none
    q.drop[3] = true;
    let (g, dropped) = r.fix_rows(&q, None, "gnss.position_std").unwrap();
    assert_eq!((g.len(), dropped), (0, 989));
    // given σ replace the messages'
    let q = QualityFactors::default();
    let (g, _) = r.fix_rows(&q, Some([1.0, 2.0, 3.0]), "k").unwrap();
    assert_eq!(&g[4..7], &[1.0, 2.0, 3.0]);
}

#[test]
fn mcap_copies_read_the_same_in_both_encodings() {
    let dir = std::env::temp_dir().join(format!("ros-mcap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let original = Recording::read(&bag(), &all(Stamps::Header), KEYS).unwrap();
    for (encoding, name) in [(Encoding::Ros1, "ros1.mcap"), (Encoding::Cdr, "cdr.mcap")] {
        let out = dir.join(name);
        let (written, left) = write_mcap(&bag(), &out, encoding, &[]).unwrap();
        assert_eq!((written, left), (11_865 + 989 + 3_952, 0));
        for stamps in [Stamps::Header, Stamps::Receive] {
            let a = Recording::read(&bag(), &all(stamps), KEYS).unwrap();
            let mut b = Recording::read(&out, &all(stamps), KEYS).unwrap();
            assert_eq!(b.container, Container::Mcap);
            // ROS 2 type names in the CDR copy; everything else equal
            for t in &mut b.topics {
                t.type_name = t.type_name.replace("/msg/", "/");
            }
            b.path = a.path.clone();
            b.container = a.container;
            assert_eq!(a, b, "{name} {stamps:?}");
        }
    }
    assert_eq!(original.imu.len(), 11_865);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_encodings_round_trip_and_cdr_aligns() {
    // every IMU, fix and odometry message of the bag: ROS 1 bytes → struct → the same bytes
    let mut checked = 0;
    for_each_message(&bag(), |c, _, _, data| {
        let again = match Kind::of(&c.type_name).unwrap() {
            Kind::Imu => {
                encode(&decode::<Imu<Header1>>(data, Encoding::Ros1).unwrap(), Encoding::Ros1)
            }
            Kind::NavSatFix => {
                encode(&decode::<NavSatFix<Header1>>(data, Encoding::Ros1).unwrap(), Encoding::Ros1)
            }
            Kind::Odometry => {
                encode(&decode::<Odometry<Header1>>(data, Encoding::Ros1).unwrap(), Encoding::Ros1)
            }
            Kind::Tf => unreachable!("the bag has no /tf_static"),
        }
        .unwrap();
        assert_eq!(again, data);
        checked += 1;
        Ok(())
    })
    .unwrap();
    assert_eq!(checked, 16_806);
    // CDR's layout by hand: the header (4 + 4 + 4 + "imu_link\0" = 21 bytes) is padded to
    // 24 before the f64s: 4 (encapsulation) + 24 + the quaternion and its covariance (4·8
    // + 9·8) + twice a vector and its covariance (3·8 + 9·8) = 324 bytes
    let mut m = None;
    for_each_message(&bag(), |c, _, _, data| {
        if m.is_none() && Kind::of(&c.type_name) == Some(Kind::Imu) {
            m = Some(decode::<Imu<Header1>>(data, Encoding::Ros1).unwrap());
        }
        Ok(())
    })
    .unwrap();
    let m = msg::imu_to_ros2(&m.unwrap());
    let bytes = encode(&m, Encoding::Cdr).unwrap();
    assert_eq!(bytes.len(), 4 + 24 + (32 + 72) + 2 * (24 + 72));
    assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
    assert_eq!(&bytes[4 + 8..4 + 12], &9u32.to_le_bytes());
    assert_eq!(&bytes[4 + 12..4 + 21], b"imu_link\0");
    assert_eq!(&bytes[4 + 21..4 + 24], &[0, 0, 0]);
    assert_eq!(decode::<Imu<Header2>>(&bytes, Encoding::Cdr).unwrap(), m);
    // a truncated message, or one of another type, is refused
    assert!(decode::<Imu<Header2>>(&bytes[..100], Encoding::Cdr).is_err());
    let fix_bytes = {
        let mut v = None;
        for_each_message(&bag(), |c, _, _, data| {
            if v.is_none() && Kind::of(&c.type_name) == Some(Kind::NavSatFix) {
                v = Some(data.to_vec());
            }
            Ok(())
        })
        .unwrap();
        v.unwrap()
    };
    assert!(decode::<Odometry<Header1>>(&fix_bytes, Encoding::Ros1).is_err());
    let mut longer = fix_bytes.clone();
    longer.extend_from_slice(&[0; 8]);
    assert!(decode::<NavSatFix<Header1>>(&longer, Encoding::Ros1).is_err());
}

#[test]
fn bad_selections_and_files_are_refused_with_the_key() {
    let named = |imu: &str| Selection { imu: Some(imu.into()), ..all(Stamps::Header) };
    let e = Recording::read(&bag(), &named("/imu"), KEYS).unwrap_err().to_string();
    assert!(e.contains("data.ros.imu_topic") && e.contains("not in the recording"), "{e}");
    assert!(e.contains("/imu/data (sensor_msgs/Imu)"), "{e}");
    let e = Recording::read(&bag(), &named("/fix"), KEYS).unwrap_err().to_string();
    assert!(e.contains("is a sensor_msgs/NavSatFix topic"), "{e}");
    // not a recording
    let text = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let e = Recording::read(&text, &all(Stamps::Header), KEYS).unwrap_err().to_string();
    assert!(e.contains("neither a ROS 1 bag"), "{e}");
    // a bag cut short: its chunk cannot be read, and the error names the message
    let dir = std::env::temp_dir().join(format!("ros-cut-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cut = dir.join("cut.bag");
    let bytes = std::fs::read(bag()).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = Recording::read(&cut, &all(Stamps::Header), KEYS).unwrap_err().to_string();
    assert!(e.contains("no index") && e.contains("rosbag reindex"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn corrupted_recordings_are_errors_not_panics() {
    // one byte changed at a time, at 60 places through the bag and its MCAP copy: each read
    // ends in a recording or an error, never a panic
    let dir = std::env::temp_dir().join(format!("ros-corrupt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mcap = dir.join("copy.mcap");
    write_mcap(&bag(), &mcap, Encoding::Cdr, &[]).unwrap();
    let (mut errors, mut panics) = (0, 0);
    for (source, name) in [(bag(), "c.bag"), (mcap, "c.mcap")] {
        let bytes = std::fs::read(&source).unwrap();
        for k in 0..30 {
            let mut b = bytes.clone();
            let at = 20 + (b.len() - 40) * k / 30 + k * 7;
            b[at] ^= 0x5a;
            let path = dir.join(name);
            std::fs::write(&path, &b).unwrap();
            let read = std::panic::catch_unwind(|| {
                Recording::read(&path, &all(Stamps::Header), KEYS).map(|r| r.imu.len())
            });
            match read {
                Ok(Ok(_)) => {}
                Ok(Err(_)) => errors += 1,
                Err(_) => panics += 1,
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(panics, 0, "{errors} errors");
    assert!(errors > 0);
}

#[test]
fn static_transforms_chain_and_read_back_from_a_copy() {
    // `static_transform_publisher`'s two forms give the same rotation
    let euler = StaticTransform::from_publisher_args("1 2 3 0.3 -0.2 0.1 /base_link imu").unwrap();
    let q = nalgebra::UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3);
    let quat = StaticTransform::from_publisher_args(&format!(
        "1 2 3 {} {} {} {} base_link imu",
        q.i, q.j, q.k, q.w
    ))
    .unwrap();
    assert_eq!((euler.parent.as_str(), euler.child.as_str()), ("base_link", "imu"));
    for k in 0..4 {
        assert!((euler.rotation[k] - quat.rotation[k]).abs() < 1e-15);
    }
    for bad in ["1 2 3 0 0 0 a", "1 2 x 0 0 0 a b", "1 2 3 0 0 0 2 a b", "1 2 NaN 0 0 0 a b"] {
        assert!(StaticTransform::from_publisher_args(bad).is_err(), "{bad}");
    }
    // base → a: 1 m forward, turned 90° left; a → b: 1 m along a's y. So b sits at the
    // base's origin, turned 90°; and the way back is the inverse
    let mut r = Recording::read(&bag(), &Selection::default(), KEYS).unwrap();
    r.transforms = vec![
        StaticTransform::from_publisher_args("1 0 0 1.5707963267948966 0 0 base a").unwrap(),
        StaticTransform::from_publisher_args("0 1 0 0 0 0 a b").unwrap(),
    ];
    let (rot, t) = r.transform("base", "b").unwrap();
    assert!(t.norm() < 1e-12, "{t}");
    assert!((rot * nalgebra::Vector3::x() - nalgebra::Vector3::y()).norm() < 1e-12);
    let (back, tb) = r.transform("b", "/base").unwrap();
    assert!((back * rot - nalgebra::Matrix3::identity()).norm() < 1e-12 && tb.norm() < 1e-12);
    assert!(r.transform("base", "c").is_none());
    // written into an MCAP copy (ROS 1 and CDR), read back from /tf_static
    let dir = std::env::temp_dir().join(format!("ros-tf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for encoding in [Encoding::Ros1, Encoding::Cdr] {
        let out = dir.join("tf.mcap");
        let (written, _) = write_mcap(&bag(), &out, encoding, &r.transforms).unwrap();
        assert_eq!(written, 16_807);
        let copy = Recording::read(&out, &Selection::default(), KEYS).unwrap();
        assert_eq!(copy.transforms, r.transforms, "{encoding:?}");
        assert!(copy.topics.iter().any(|t| t.name == TF_STATIC && t.messages == 1));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
