//! ROS recordings: ROS 1 bags (`rosbag`: bz2 and lz4 chunks) and MCAP files (`mcap`: ROS 1
//! or ROS 2 CDR messages), read into the rows of the IMU and GNSS formats.
//!
//! A run reads three message types: `sensor_msgs/Imu` (angular velocity and specific
//! force, and their covariances when asked), `sensor_msgs/NavSatFix` (position, its ENU
//! covariance by `position_covariance_type`, the status as a quality) and, for the
//! odometer update, `nav_msgs/Odometry` (the forward speed of its twist, in its child
//! frame). Each topic is chosen by name, or found by type when the recording has one
//! topic of it. Messages are ordered by their header stamps or by the times they were
//! recorded, as chosen; times are Unix UTC and become GPST seconds of week.
//!
//! Errors name the recording and the message's 1-based position in it (`test1.bag:#412`);
//! the readers' later errors name the topic and the row (the message's position on its
//! topic in time order).

mod container;
mod msg;
mod rows;
mod tf;
mod write;

pub use container::Container;
pub(crate) use container::{for_each_message, Channel};
use tf::frame_name;
pub use tf::{StaticTransform, TF_STATIC};
pub use write::write_mcap;

pub use msg::{
    decode, encode, Encoding, Header, Header1, Header2, Imu, Kind, NavSatFix, Odometry, Quat,
    TfMessage, TransformStamped, Vec3,
};

use crate::lines::{LineError, LineErrorKind};
use crate::rtklib::QualityFactors;
use crate::TimeScale;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Which message times order the messages and stamp the samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Stamps {
    /// The messages' header stamps (when the sensor measured).
    #[default]
    Header,
    /// The times the recorder received them.
    Receive,
}

/// A topic of the recording.
#[derive(Clone, Debug, PartialEq)]
pub struct Topic {
    /// Its name.
    pub name: String,
    /// Its message type as the recording names it.
    pub type_name: String,
    /// Its messages.
    pub messages: usize,
}

/// What to read: topic names (`None`: the recording's only topic of that type), which
/// stamps, and whether the odometry is wanted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection {
    /// The `sensor_msgs/Imu` topic.
    pub imu: Option<String>,
    /// The `sensor_msgs/NavSatFix` topic.
    pub fix: Option<String>,
    /// The `nav_msgs/Odometry` topic.
    pub odometry: Option<String>,
    /// Read the odometry (for the odometer update).
    pub use_odometry: bool,
    /// Header or receive times.
    pub stamps: Stamps,
}

/// One IMU message.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuRecord {
    /// Unix time, s.
    pub t: f64,
    /// Angular velocity, rad/s.
    pub w: [f64; 3],
    /// Specific force, m/s².
    pub f: [f64; 3],
    /// The diagonals of their covariances (NaN where the message gives none).
    pub w_var: [f64; 3],
    /// The specific force's.
    pub f_var: [f64; 3],
}

/// One NavSatFix message.
#[derive(Clone, Debug, PartialEq)]
pub struct FixRecord {
    /// Unix time, s.
    pub t: f64,
    /// −1 no fix, 0 fix, 1 SBAS, 2 GBAS.
    pub status: i8,
    /// Latitude, longitude (deg), ellipsoidal height (m).
    pub position: [f64; 3],
    /// East, north, up variances, m².
    pub var_enu: [f64; 3],
    /// 0 unknown, 1 approximated, 2 diagonal known, 3 known.
    pub covariance_type: u8,
}

/// One Odometry message: its time and forward speed.
#[derive(Clone, Debug, PartialEq)]
pub struct OdometryRecord {
    /// Unix time, s.
    pub t: f64,
    /// Forward speed (`twist.linear.x` in the child frame), m/s.
    pub speed: f64,
}

/// A recording's messages of the selected topics, in time order.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// The file.
    pub path: PathBuf,
    /// Bag or MCAP.
    pub container: Container,
    /// Every topic of the file.
    pub topics: Vec<Topic>,
    /// The IMU topic and its frame id.
    pub imu_topic: (String, String),
    /// The NavSatFix topic and its frame id.
    pub fix_topic: (String, String),
    /// The odometry topic and its child frame id, when read.
    pub odometry_topic: Option<(String, String)>,
    /// The IMU messages.
    pub imu: Vec<ImuRecord>,
    /// The NavSatFix messages.
    pub fixes: Vec<FixRecord>,
    /// The odometry messages.
    pub odometry: Vec<OdometryRecord>,
    /// The static transforms (`/tf_static`), each parent–child pair once.
    pub transforms: Vec<StaticTransform>,
}

/// What a message on one of the three types decodes into.
enum Decoded {
    Imu(ImuRecord, String),
    Fix(FixRecord, String),
    Odometry(OdometryRecord, String),
    Tf(Vec<StaticTransform>),
}

fn located(path: &Path, index: usize, message: String) -> LineError {
    LineError { path: path.to_path_buf(), line: index, kind: LineErrorKind::Invalid(message) }
}

fn file_error(path: &Path, message: String) -> LineError {
    LineError { path: path.to_path_buf(), line: 0, kind: LineErrorKind::Io(message) }
}

/// Covariance diagonal, NaN when the message says it has none (all zero, or −1 first).
fn diagonal(c: &[f64; 9]) -> [f64; 3] {
    if c[0] == -1.0 || c.iter().all(|&v| v == 0.0) {
        [f64::NAN; 3]
    } else {
        [c[0], c[4], c[8]]
    }
}

fn decode_as(
    kind: Kind,
    data: &[u8],
    encoding: Encoding,
    receive: f64,
    stamps: Stamps,
) -> Result<Decoded, String> {
    fn pick<H: Header>(h: &H, receive: f64, stamps: Stamps) -> f64 {
        match stamps {
            Stamps::Header => h.stamp(),
            Stamps::Receive => receive,
        }
    }
    fn imu<H: Header>(m: Imu<H>, receive: f64, stamps: Stamps) -> Decoded {
        let r = ImuRecord {
            t: pick(&m.header, receive, stamps),
            w: m.angular_velocity.array(),
            f: m.linear_acceleration.array(),
            w_var: diagonal(&m.angular_velocity_covariance),
            f_var: diagonal(&m.linear_acceleration_covariance),
        };
        Decoded::Imu(r, m.header.frame().to_string())
    }
    fn fix<H: Header>(m: NavSatFix<H>, receive: f64, stamps: Stamps) -> Decoded {
        let c = &m.position_covariance;
        let r = FixRecord {
            t: pick(&m.header, receive, stamps),
            status: m.status.status,
            position: [m.latitude, m.longitude, m.altitude],
            var_enu: [c[0], c[4], c[8]],
            covariance_type: m.position_covariance_type,
        };
        Decoded::Fix(r, m.header.frame().to_string())
    }
    fn odometry<H: Header>(m: Odometry<H>, receive: f64, stamps: Stamps) -> Decoded {
        let r = OdometryRecord { t: pick(&m.header, receive, stamps), speed: m.twist.linear.x };
        Decoded::Odometry(r, m.child_frame_id)
    }
    fn tf<H: Header>(m: TfMessage<H>) -> Decoded {
        let list = m
            .transforms
            .into_iter()
            .map(|t| StaticTransform {
                parent: frame_name(t.header.frame()).to_string(),
                child: frame_name(&t.child_frame_id).to_string(),
                translation: t.translation.array(),
                rotation: [t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w],
            })
            .collect();
        Decoded::Tf(list)
    }
    Ok(match (kind, encoding) {
        (Kind::Tf, Encoding::Ros1) => tf::<Header1>(decode(data, encoding)?),
        (Kind::Tf, Encoding::Cdr) => tf::<Header2>(decode(data, encoding)?),
        (Kind::Imu, Encoding::Ros1) => imu::<Header1>(decode(data, encoding)?, receive, stamps),
        (Kind::Imu, Encoding::Cdr) => imu::<Header2>(decode(data, encoding)?, receive, stamps),
        (Kind::NavSatFix, Encoding::Ros1) => {
            fix::<Header1>(decode(data, encoding)?, receive, stamps)
        }
        (Kind::NavSatFix, Encoding::Cdr) => {
            fix::<Header2>(decode(data, encoding)?, receive, stamps)
        }
        (Kind::Odometry, Encoding::Ros1) => {
            odometry::<Header1>(decode(data, encoding)?, receive, stamps)
        }
        (Kind::Odometry, Encoding::Cdr) => {
            odometry::<Header2>(decode(data, encoding)?, receive, stamps)
        }
    })
}

/// The per-topic messages of one kind, with their frames.
#[derive(Default)]
struct Gathered {
    imu: BTreeMap<String, (Vec<ImuRecord>, String)>,
    fix: BTreeMap<String, (Vec<FixRecord>, String)>,
    odometry: BTreeMap<String, (Vec<OdometryRecord>, String)>,
}

/// The chosen topic of one kind: named, or the only one of that type.
fn choose<T>(
    kind: Kind,
    key: &str,
    named: Option<&str>,
    found: &mut BTreeMap<String, (Vec<T>, String)>,
    topics: &[Topic],
) -> Result<(String, Vec<T>, String), String> {
    let name = match named {
        Some(n) => n.to_string(),
        None => match found.keys().collect::<Vec<_>>().as_slice() {
            [one] => one.to_string(),
            [] => return Err(format!("`{key}`: the recording has no {} topic", kind.ros1_name())),
            many => {
                let names: Vec<&str> = many.iter().map(|s| s.as_str()).collect();
                return Err(format!(
                    "`{key}`: the recording has {} {} topics ({}); name one",
                    many.len(),
                    kind.ros1_name(),
                    names.join(", ")
                ));
            }
        },
    };
    match found.remove(&name) {
        Some((records, frame)) => Ok((name, records, frame)),
        None => {
            let listed: Vec<String> =
                topics.iter().map(|t| format!("{} ({})", t.name, t.type_name)).collect();
            let what = match topics.iter().find(|t| t.name == name) {
                Some(t) => format!("is a {} topic", t.type_name),
                None => "is not in the recording".into(),
            };
            Err(format!(
                "`{key}`: `{name}` {what}, not {}; its topics: {}",
                kind.ros1_name(),
                listed.join(", ")
            ))
        }
    }
}

impl Recording {
    /// Read the selected topics of a ROS 1 bag or an MCAP file. `keys` names the
    /// configuration keys of the IMU, NavSatFix and odometry topics in errors.
    pub fn read(path: &Path, select: &Selection, keys: [&str; 3]) -> Result<Self, LineError> {
        let mut topics: Vec<Topic> = Vec::new();
        let mut gathered = Gathered::default();
        let mut transforms: Vec<StaticTransform> = Vec::new();
        let wanted = |kind: Kind, topic: &str| match kind {
            Kind::Imu => select.imu.as_deref().is_none_or(|n| n == topic),
            Kind::NavSatFix => select.fix.as_deref().is_none_or(|n| n == topic),
            Kind::Odometry => {
                select.use_odometry && select.odometry.as_deref().is_none_or(|n| n == topic)
            }
            Kind::Tf => topic == TF_STATIC,
        };
        let container = for_each_message(path, |channel, index, receive_ns, data| {
            match topics.iter_mut().find(|t| t.name == channel.topic) {
                Some(t) => t.messages += 1,
                None => topics.push(Topic {
                    name: channel.topic.clone(),
                    type_name: channel.type_name.clone(),
                    messages: 1,
                }),
            }
            let Some(kind) = Kind::of(&channel.type_name) else { return Ok(()) };
            if !wanted(kind, &channel.topic) {
                return Ok(());
            }
            let Some(encoding) = channel.encoding else {
                return Err(located(
                    path,
                    index,
                    format!("{}: a message encoding other than ros1 or cdr", channel.topic),
                ));
            };
            let receive = receive_ns as f64 * 1e-9;
            let decoded = decode_as(kind, data, encoding, receive, select.stamps).map_err(|e| {
                located(path, index, format!("{} ({}): {e}", channel.topic, channel.type_name))
            })?;
            gathered
                .keep(decoded, &channel.topic, &mut transforms)
                .map_err(|m| located(path, index, m))?;
            Ok(())
        })?;
        let refuse = |m: String| file_error(path, m);
        let (imu_name, mut imu, imu_frame) =
            choose(Kind::Imu, keys[0], select.imu.as_deref(), &mut gathered.imu, &topics)
                .map_err(refuse)?;
        let (fix_name, mut fixes, fix_frame) =
            choose(Kind::NavSatFix, keys[1], select.fix.as_deref(), &mut gathered.fix, &topics)
                .map_err(refuse)?;
        let (odometry_topic, mut odometry) = if select.use_odometry {
            let (n, o, f) = choose(
                Kind::Odometry,
                keys[2],
                select.odometry.as_deref(),
                &mut gathered.odometry,
                &topics,
            )
            .map_err(refuse)?;
            (Some((n, f)), o)
        } else {
            (None, Vec::new())
        };
        // time order (stable: equal times keep the file's order, and the readers refuse them)
        imu.sort_by(|a, b| a.t.total_cmp(&b.t));
        fixes.sort_by(|a, b| a.t.total_cmp(&b.t));
        odometry.sort_by(|a, b| a.t.total_cmp(&b.t));
        Ok(Recording {
            path: path.to_path_buf(),
            container,
            topics,
            imu_topic: (imu_name, imu_frame),
            fix_topic: (fix_name, fix_frame),
            odometry_topic,
            imu,
            fixes,
            odometry,
            transforms,
        })
    }
}

impl Gathered {
    /// A decoded message kept under its topic (one from another frame than the topic's
    /// earlier messages is refused: one mounting cannot serve both), a static transform
    /// once.
    fn keep(
        &mut self,
        decoded: Decoded,
        topic: &str,
        transforms: &mut Vec<StaticTransform>,
    ) -> Result<(), String> {
        let check_frame = |frame: &mut String, new: String| {
            if frame.is_empty() || *frame == new {
                *frame = new;
                Ok(())
            } else {
                Err(format!(
                    "{topic}: frame `{new}` where the earlier messages have `{frame}`: one \
                     mounting cannot serve both"
                ))
            }
        };
        match decoded {
            Decoded::Imu(r, f) => {
                let e = self.imu.entry(topic.to_string()).or_default();
                check_frame(&mut e.1, f)?;
                e.0.push(r);
            }
            Decoded::Fix(r, f) => {
                let e = self.fix.entry(topic.to_string()).or_default();
                check_frame(&mut e.1, f)?;
                e.0.push(r);
            }
            Decoded::Odometry(r, f) => {
                let e = self.odometry.entry(topic.to_string()).or_default();
                check_frame(&mut e.1, f)?;
                e.0.push(r);
            }
            Decoded::Tf(list) => {
                for t in list {
                    if !transforms.iter().any(|u| u.parent == t.parent && u.child == t.child) {
                        transforms.push(t);
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
