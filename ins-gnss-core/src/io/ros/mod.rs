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

mod msg;

pub use msg::{
    decode, encode, Encoding, Header, Header1, Header2, Imu, Kind, NavSatFix, Odometry, Quat,
    TfMessage, TransformStamped, Vec3,
};

use crate::io::lines::{LineError, LineErrorKind};
use crate::io::rtklib::QualityFactors;
use crate::io::TimeScale;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The file layout of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// A ROS 1 bag (format 2.0).
    Bag,
    /// An MCAP file.
    Mcap,
}

impl Container {
    /// The layout of a file, from its first bytes.
    pub fn detect(head: &[u8]) -> Option<Container> {
        if head.starts_with(b"#ROSBAG V2.0") {
            Some(Container::Bag)
        } else if head.starts_with(b"\x89MCAP0\r\n") {
            Some(Container::Mcap)
        } else {
            None
        }
    }
}

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

/// A transform of `/tf_static`: the child frame's origin and axes in the parent frame.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticTransform {
    /// The parent frame (a leading `/` removed).
    pub parent: String,
    /// The child frame.
    pub child: String,
    /// The child's origin in the parent frame, m.
    pub translation: [f64; 3],
    /// The child's axes in the parent frame, as a quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl StaticTransform {
    /// A transform as `static_transform_publisher`'s arguments give it: `x y z yaw pitch
    /// roll parent child` (m, rad; the rotation `R_z(yaw) R_y(pitch) R_x(roll)`) or `x y z
    /// qx qy qz qw parent child`.
    pub fn from_publisher_args(text: &str) -> Result<Self, String> {
        let f: Vec<&str> = text.split_whitespace().collect();
        let n = f.len();
        if n != 8 && n != 9 {
            return Err(format!(
                "`{text}`: give `x y z yaw pitch roll parent child` or `x y z qx qy qz qw \
                 parent child` ({n} fields)"
            ));
        }
        let v: Vec<f64> = f[..n - 2]
            .iter()
            .map(|s| s.parse::<f64>().map_err(|_| format!("`{text}`: `{s}` is not a number")))
            .collect::<Result<_, _>>()?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("`{text}`: a number is not finite"));
        }
        let rotation = if n == 8 {
            let q = nalgebra::UnitQuaternion::from_euler_angles(v[5], v[4], v[3]);
            [q.i, q.j, q.k, q.w]
        } else {
            let norm = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]).sqrt();
            if (norm - 1.0).abs() > 1e-3 {
                return Err(format!("`{text}`: the quaternion's norm is {norm}, not 1"));
            }
            [v[3] / norm, v[4] / norm, v[5] / norm, v[6] / norm]
        };
        Ok(StaticTransform {
            parent: frame_name(f[n - 2]).to_string(),
            child: frame_name(f[n - 1]).to_string(),
            translation: [v[0], v[1], v[2]],
            rotation,
        })
    }
}

/// A frame name as tf compares them: without a leading `/`.
fn frame_name(f: &str) -> &str {
    f.strip_prefix('/').unwrap_or(f)
}

/// The topic whose `tf2_msgs/TFMessage` messages are read: the static transforms.
pub const TF_STATIC: &str = "/tf_static";

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

/// A topic as a message stream sees it.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    pub(crate) topic: String,
    pub(crate) type_name: String,
    /// `None`: an encoding this reader does not decode.
    pub(crate) encoding: Option<Encoding>,
    /// The schema text (ROS 1: the message definition), for a copy.
    pub(crate) definition: Vec<u8>,
}

/// Call `each(channel, index, receive_ns, data)` on every message of the file, in file
/// order (`index` 1-based).
pub(crate) fn for_each_message(
    path: &Path,
    mut each: impl FnMut(&Channel, usize, u64, &[u8]) -> Result<(), LineError>,
) -> Result<Container, LineError> {
    let mut head = [0u8; 16];
    {
        use std::io::Read;
        let mut f = std::fs::File::open(path).map_err(|e| file_error(path, e.to_string()))?;
        let n = f.read(&mut head).map_err(|e| file_error(path, e.to_string()))?;
        if Container::detect(&head[..n]).is_none() {
            return Err(file_error(
                path,
                "neither a ROS 1 bag (`#ROSBAG V2.0`) nor an MCAP file (`\\x89MCAP0`)".into(),
            ));
        }
    }
    let container = Container::detect(&head).unwrap_or(Container::Bag);
    let mut index = 0usize;
    match container {
        Container::Bag => {
            check_bag_index(path)?;
            let bag = rosbag::RosBag::new(path).map_err(|e| file_error(path, e.to_string()))?;
            let mut channels: BTreeMap<u32, Channel> = BTreeMap::new();
            for record in bag.chunk_records() {
                let record = record.map_err(|e| located(path, index + 1, e.to_string()))?;
                let rosbag::ChunkRecord::Chunk(chunk) = record else { continue };
                for m in chunk.messages() {
                    match m.map_err(|e| located(path, index + 1, e.to_string()))? {
                        rosbag::MessageRecord::Connection(c) => {
                            channels.insert(
                                c.id,
                                Channel {
                                    topic: c.topic.to_string(),
                                    type_name: c.tp.to_string(),
                                    encoding: Some(Encoding::Ros1),
                                    definition: c.message_definition.as_bytes().to_vec(),
                                },
                            );
                        }
                        rosbag::MessageRecord::MessageData(d) => {
                            index += 1;
                            let Some(channel) = channels.get(&d.conn_id) else {
                                return Err(located(
                                    path,
                                    index,
                                    format!("message on connection {} before it", d.conn_id),
                                ));
                            };
                            each(channel, index, d.time, d.data)?;
                        }
                    }
                }
            }
        }
        Container::Mcap => {
            let bytes = std::fs::read(path).map_err(|e| file_error(path, e.to_string()))?;
            let stream =
                mcap::MessageStream::new(&bytes).map_err(|e| file_error(path, e.to_string()))?;
            let mut channels: BTreeMap<u16, Channel> = BTreeMap::new();
            for m in stream {
                let m = m.map_err(|e| located(path, index + 1, e.to_string()))?;
                index += 1;
                let channel = channels.entry(m.channel.id).or_insert_with(|| {
                    let schema = m.channel.schema.as_ref();
                    Channel {
                        topic: m.channel.topic.clone(),
                        type_name: schema.map(|s| s.name.clone()).unwrap_or_default(),
                        encoding: match m.channel.message_encoding.as_str() {
                            "ros1" => Some(Encoding::Ros1),
                            "cdr" => Some(Encoding::Cdr),
                            _ => None,
                        },
                        definition: schema.map(|s| s.data.to_vec()).unwrap_or_default(),
                    }
                });
                each(channel, index, m.log_time, &m.data)?;
            }
        }
    }
    Ok(container)
}

/// A bag's header names where its index starts; a bag whose recording did not finish (a
/// `.bag.active`, or one cut short) has none, or one past its end. `rosbag` indexes past
/// the end of the file then, so the header is checked first.
fn check_bag_index(path: &Path) -> Result<(), LineError> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| file_error(path, e.to_string()))?;
    let len = f.metadata().map_err(|e| file_error(path, e.to_string()))?.len();
    let mut head = vec![0u8; 4096];
    let n = f.read(&mut head).map_err(|e| file_error(path, e.to_string()))?;
    head.truncate(n);
    // after the version line: the header record's length, then `len` + `name=value` fields
    let fields = head.iter().position(|&b| b == b'\n').map(|p| p + 1).and_then(|p| {
        let size = u32::from_le_bytes(head.get(p..p + 4)?.try_into().ok()?) as usize;
        head.get(p + 4..p + 4 + size)
    });
    let mut index_pos = None;
    let mut rest = fields.unwrap_or(&[]);
    while rest.len() >= 4 {
        let size = u32::from_le_bytes([rest[0], rest[1], rest[2], rest[3]]) as usize;
        let Some(field) = rest.get(4..4 + size) else { break };
        if let Some(v) = field.strip_prefix(b"index_pos=") {
            index_pos = v.try_into().ok().map(u64::from_le_bytes);
        }
        rest = &rest[4 + size..];
    }
    match index_pos {
        Some(p) if p > 13 && p <= len => Ok(()),
        _ => Err(file_error(
            path,
            "the bag has no index (its recording did not finish, or the file is cut short): \
             `rosbag reindex` rebuilds it"
                .into(),
        )),
    }
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
            let topic = channel.topic.clone();
            let check_frame = |frame: &mut String, new: String| {
                if frame.is_empty() || *frame == new {
                    *frame = new;
                    Ok(())
                } else {
                    Err(located(
                        path,
                        index,
                        format!(
                            "{}: frame `{new}` where the earlier messages have `{frame}`: one \
                             mounting cannot serve both",
                            channel.topic
                        ),
                    ))
                }
            };
            match decoded {
                Decoded::Imu(r, f) => {
                    let e = gathered.imu.entry(topic).or_default();
                    check_frame(&mut e.1, f)?;
                    e.0.push(r);
                }
                Decoded::Fix(r, f) => {
                    let e = gathered.fix.entry(topic).or_default();
                    check_frame(&mut e.1, f)?;
                    e.0.push(r);
                }
                Decoded::Odometry(r, f) => {
                    let e = gathered.odometry.entry(topic).or_default();
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

    /// Where frame `to` is in frame `from` through the static transforms (chained, either
    /// way along each): its axes `R` (a vector in `to` is `R v` in `from`) and its origin
    /// `t` in `from`, m. `None` when the transforms do not connect them.
    pub fn transform(
        &self,
        from: &str,
        to: &str,
    ) -> Option<(nalgebra::Matrix3<f64>, nalgebra::Vector3<f64>)> {
        use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
        let (from, to) = (frame_name(from), frame_name(to));
        // edges both ways: parent → child as given, child → parent inverted
        let mut edges: Vec<(&str, &str, Matrix3<f64>, Vector3<f64>)> = Vec::new();
        for t in &self.transforms {
            let [x, y, z, w] = t.rotation;
            let r = *UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
                .to_rotation_matrix()
                .matrix();
            let p = Vector3::from(t.translation);
            edges.push((&t.parent, &t.child, r, p));
            edges.push((&t.child, &t.parent, r.transpose(), -(r.transpose() * p)));
        }
        // breadth first from `from`, composing poses
        let mut seen = vec![(from, Matrix3::identity(), Vector3::zeros())];
        let mut k = 0;
        while k < seen.len() {
            let (frame, r, p) = seen[k];
            if frame == to {
                return Some((r, p));
            }
            for (a, b, r2, p2) in &edges {
                if *a == frame && !seen.iter().any(|(f, _, _)| f == b) {
                    seen.push((b, r * r2, p + r * p2));
                }
            }
            k += 1;
        }
        None
    }

    /// The offset that takes the recording's Unix times to GPST seconds of week (taken at
    /// the first IMU message, kept for the whole recording).
    pub fn gpst_offset(&self) -> f64 {
        let t0 = self.imu.first().map_or(0.0, |r| r.t);
        TimeScale::UnixUtc.offset_at(t0)
    }

    /// The IMU's rate, Hz: the median interval of its messages.
    pub fn imu_rate(&self) -> Option<f64> {
        let mut dt: Vec<f64> = self.imu.windows(2).map(|w| w[1].t - w[0].t).collect();
        if dt.is_empty() {
            return None;
        }
        dt.sort_by(f64::total_cmp);
        let median = dt[dt.len() / 2];
        (median > 0.0).then(|| 1.0 / median)
    }

    /// The median of the IMU messages' covariance diagonals, σ per sample (rad/s and
    /// m/s²), when they give them.
    pub fn imu_sigma(&self) -> Option<([f64; 3], [f64; 3])> {
        let median = |get: &dyn Fn(&ImuRecord) -> f64| {
            let mut v: Vec<f64> =
                self.imu.iter().map(get).filter(|v| v.is_finite() && *v > 0.0).collect();
            if v.len() < self.imu.len() / 2 || v.is_empty() {
                return None;
            }
            v.sort_by(f64::total_cmp);
            Some(v[v.len() / 2].sqrt())
        };
        let mut w = [0.0; 3];
        let mut f = [0.0; 3];
        for i in 0..3 {
            w[i] = median(&|r: &ImuRecord| r.w_var[i])?;
            f[i] = median(&|r: &ImuRecord| r.f_var[i])?;
        }
        Some((w, f))
    }

    /// The IMU rows of the rates format (`t` in GPST seconds of week, ω in rad/s, f in
    /// m/s²), with the odometry's forward speed as an 8th column when read (linear
    /// between the odometry messages around each sample, held before the first and
    /// after the last). Returns the rows, their width and the longest odometry interval
    /// a sample fell in, s.
    pub fn imu_rows(&self) -> (Vec<f64>, usize, f64) {
        let offset = self.gpst_offset();
        let width = if self.odometry_topic.is_some() { 8 } else { 7 };
        let mut rows = Vec::with_capacity(self.imu.len() * width);
        let mut longest: f64 = 0.0;
        let mut k = 0;
        for r in &self.imu {
            rows.push(r.t + offset);
            rows.extend_from_slice(&r.w);
            rows.extend_from_slice(&r.f);
            if width == 8 {
                let o = &self.odometry;
                while k + 1 < o.len() && o[k + 1].t <= r.t {
                    k += 1;
                }
                let speed = match (o.get(k), o.get(k + 1)) {
                    (Some(a), Some(b)) if a.t <= r.t && b.t > a.t => {
                        longest = longest.max(b.t - a.t);
                        a.speed + (b.speed - a.speed) * (r.t - a.t) / (b.t - a.t)
                    }
                    (Some(a), _) => a.speed,
                    (None, _) => 0.0,
                };
                rows.push(speed);
            }
        }
        (rows, width, longest)
    }

    /// The GNSS rows of the 7-column format (`t`, latitude and longitude in degrees,
    /// height, σ N E D in m). A fix without a position (status −1) is left out, as are
    /// the statuses `quality` drops (status 0 as `single`, 1 SBAS as `sbas`, 2 GBAS as
    /// `dgps`). The σ are the message's covariance as it is: `quality`'s factors, which
    /// make up for RTKLIB's and NMEA's optimistic σ, are not applied (on the Husky bag
    /// the SBAS factor 5 left the innovations at 0.21× their σ; as given, 0.42×). A fix
    /// whose covariance is unknown (type 0) takes `sigma` (N, E, D), and is refused
    /// without it; `sigma` replaces every fix's when given. Returns the rows and the
    /// fixes left out.
    pub fn fix_rows(
        &self,
        quality: &QualityFactors,
        sigma: Option<[f64; 3]>,
        sigma_key: &str,
    ) -> Result<(Vec<f64>, usize), LineError> {
        let offset = self.gpst_offset();
        let mut rows = Vec::with_capacity(self.fixes.len() * 7);
        let mut dropped = 0;
        for (i, r) in self.fixes.iter().enumerate() {
            // RTKLIB's qualities: 5 single, 3 SBAS, 4 DGPS
            let q = match r.status {
                0 => 5,
                1 => 3,
                2 => 4,
                _ => {
                    dropped += 1;
                    continue;
                }
            };
            if quality.drop[q] {
                dropped += 1;
                continue;
            }
            let s = match (r.covariance_type, sigma) {
                (_, Some(s)) => s,
                (0, None) => {
                    return Err(LineError {
                        path: PathBuf::from(format!(
                            "{} {}",
                            self.path.display(),
                            self.fix_topic.0
                        )),
                        line: i + 1,
                        kind: LineErrorKind::Invalid(format!(
                            "NavSatFix with an unknown covariance (type 0): set `{sigma_key}`"
                        )),
                    })
                }
                (_, None) => {
                    let v = r.var_enu;
                    [v[1].sqrt(), v[0].sqrt(), v[2].sqrt()]
                }
            };
            rows.push(r.t + offset);
            rows.extend_from_slice(&r.position);
            rows.extend_from_slice(&s);
        }
        Ok((rows, dropped))
    }

    /// The name the IMU rows go by in errors: the file and topic.
    pub fn imu_name(&self) -> PathBuf {
        PathBuf::from(format!("{} {}", self.path.display(), self.imu_topic.0))
    }

    /// The name the GNSS rows go by in errors.
    pub fn fix_name(&self) -> PathBuf {
        PathBuf::from(format!("{} {}", self.path.display(), self.fix_topic.0))
    }
}

/// The ROS 1 definition of `tf2_msgs/TFMessage`, for a copy's schema.
const TF_ROS1_DEFINITION: &str = concat!(
    "geometry_msgs/TransformStamped[] transforms\n",
    "================================================================================\n",
    "MSG: geometry_msgs/TransformStamped\nHeader header\nstring child_frame_id\n",
    "Transform transform\n",
    "================================================================================\n",
    "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n",
    "================================================================================\n",
    "MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation\n",
    "================================================================================\n",
    "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
    "================================================================================\n",
    "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
);

/// Write the messages of `input` (a ROS 1 bag or an MCAP file of ROS 1 messages) to an
/// MCAP file at `output`: as they are (`ros1`), or as ROS 2 CDR messages (`cdr`: the
/// IMU, NavSatFix, Odometry and TFMessage messages converted, the other topics left
/// out). `static_transforms` (e.g. what a launch file's `static_transform_publisher`
/// gave the recording's players) go first, as one message on `/tf_static`, and win over
/// the recording's own for the same pair of frames. Returns the messages written and
/// left out.
pub fn write_mcap(
    input: &Path,
    output: &Path,
    encoding: Encoding,
    static_transforms: &[StaticTransform],
) -> Result<(usize, usize), LineError> {
    let out_error = |e: String| file_error(output, e);
    // written beside, and moved over `output` only when complete
    let mut partial = output.as_os_str().to_owned();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let result = write_mcap_to(input, &partial, output, encoding, static_transforms);
    match result {
        Ok(counts) => {
            std::fs::rename(&partial, output).map_err(|e| out_error(e.to_string()))?;
            Ok(counts)
        }
        Err(e) => {
            let _ = std::fs::remove_file(&partial);
            Err(e)
        }
    }
}

fn write_mcap_to(
    input: &Path,
    partial: &Path,
    output: &Path,
    encoding: Encoding,
    static_transforms: &[StaticTransform],
) -> Result<(usize, usize), LineError> {
    let out_error = |e: String| file_error(output, e);
    let file = std::fs::File::create(partial).map_err(|e| out_error(e.to_string()))?;
    let mut writer =
        mcap::Writer::new(std::io::BufWriter::new(file)).map_err(|e| out_error(e.to_string()))?;
    let mut ids: BTreeMap<String, u16> = BTreeMap::new();
    let (mut written, mut left) = (0usize, 0usize);
    let mut sequence = 0u32;
    let mut put = |channel: &Channel, index: usize, receive_ns: u64, data: &[u8]| {
        if channel.encoding != Some(Encoding::Ros1) {
            return Err(located(input, index, format!("{}: not a ROS 1 message", channel.topic)));
        }
        let kind = Kind::of(&channel.type_name);
        let converted;
        let bytes = match encoding {
            Encoding::Ros1 => data,
            Encoding::Cdr => {
                let Some(kind) = kind else {
                    left += 1;
                    return Ok(());
                };
                let bad = |e: String| located(input, index, format!("{}: {e}", channel.topic));
                converted = match kind {
                    Kind::Imu => {
                        let m: Imu<Header1> = decode(data, Encoding::Ros1).map_err(bad)?;
                        encode(&msg::imu_to_ros2(&m), Encoding::Cdr)
                    }
                    Kind::NavSatFix => {
                        let m: NavSatFix<Header1> = decode(data, Encoding::Ros1).map_err(bad)?;
                        encode(&msg::fix_to_ros2(&m), Encoding::Cdr)
                    }
                    Kind::Odometry => {
                        let m: Odometry<Header1> = decode(data, Encoding::Ros1).map_err(bad)?;
                        encode(&msg::odometry_to_ros2(&m), Encoding::Cdr)
                    }
                    Kind::Tf => {
                        let m: TfMessage<Header1> = decode(data, Encoding::Ros1).map_err(bad)?;
                        encode(&msg::tf_to_ros2(&m), Encoding::Cdr)
                    }
                }
                .map_err(bad)?;
                &converted[..]
            }
        };
        let id = match ids.get(&channel.topic) {
            Some(&id) => id,
            None => {
                let (name, schema_encoding, definition, message_encoding) = match encoding {
                    Encoding::Ros1 => {
                        (channel.type_name.clone(), "ros1msg", channel.definition.clone(), "ros1")
                    }
                    Encoding::Cdr => {
                        let kind = kind.unwrap_or(Kind::Imu);
                        let name = kind.ros1_name().replacen('/', "/msg/", 1);
                        (name, "ros2msg", msg::ros2_definition(kind).as_bytes().to_vec(), "cdr")
                    }
                };
                let schema = writer
                    .add_schema(&name, schema_encoding, &definition)
                    .map_err(|e| out_error(e.to_string()))?;
                let id = writer
                    .add_channel(schema, &channel.topic, message_encoding, &BTreeMap::new())
                    .map_err(|e| out_error(e.to_string()))?;
                ids.insert(channel.topic.clone(), id);
                id
            }
        };
        sequence = sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence,
            log_time: receive_ns,
            publish_time: receive_ns,
        };
        writer.write_to_known_channel(&header, bytes).map_err(|e| out_error(e.to_string()))?;
        written += 1;
        Ok(())
    };
    // the given static transforms, as one ROS 1 message before the first of the input
    let tf = (!static_transforms.is_empty()).then(|| {
        let secs_of = |ns: u64| ((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32);
        let channel = Channel {
            topic: TF_STATIC.into(),
            type_name: Kind::Tf.ros1_name().into(),
            encoding: Some(Encoding::Ros1),
            definition: TF_ROS1_DEFINITION.as_bytes().to_vec(),
        };
        (channel, secs_of)
    });
    let mut first = true;
    for_each_message(input, |channel, index, receive_ns, data| {
        if let (true, Some((tf_channel, secs_of))) = (first, &tf) {
            let (secs, nsecs) = secs_of(receive_ns);
            let message = TfMessage {
                transforms: static_transforms
                    .iter()
                    .map(|t| TransformStamped {
                        header: Header1::new(secs, nsecs, &t.parent),
                        child_frame_id: t.child.clone(),
                        translation: Vec3 {
                            x: t.translation[0],
                            y: t.translation[1],
                            z: t.translation[2],
                        },
                        rotation: Quat {
                            x: t.rotation[0],
                            y: t.rotation[1],
                            z: t.rotation[2],
                            w: t.rotation[3],
                        },
                    })
                    .collect(),
            };
            let bytes = encode(&message, Encoding::Ros1).map_err(&out_error)?;
            put(tf_channel, 0, receive_ns, &bytes)?;
        }
        first = false;
        put(channel, index, receive_ns, data)
    })?;
    writer.finish().map_err(|e| out_error(e.to_string()))?;
    Ok((written, left))
}

#[cfg(test)]
mod tests;
