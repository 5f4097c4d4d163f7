//! The three ROS messages a run reads, in both wire encodings: ROS 1 (`serde_rosmsg`) and
//! ROS 2's CDR (`cdr`). The structs are the messages' full layouts, so that a message read
//! in one encoding is written in the other unchanged ([`super::write_mcap`]).

use serde::{de::DeserializeOwned, Deserialize, Serialize};

/// How a message's bytes are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 1 serialisation (a bag's messages; MCAP's `ros1`).
    Ros1,
    /// ROS 2's CDR, little or big endian (MCAP's `cdr`).
    Cdr,
}

/// `std_msgs/Header` of ROS 1 (with its sequence number).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header1 {
    seq: u32,
    secs: u32,
    nsecs: u32,
    frame_id: String,
}

/// `std_msgs/msg/Header` of ROS 2.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header2 {
    sec: i32,
    nanosec: u32,
    frame_id: String,
}

/// A header of either version: its stamp in Unix seconds and its frame.
pub trait Header: Serialize + DeserializeOwned {
    /// The stamp, s since 1970-01-01 UTC.
    fn stamp(&self) -> f64;
    /// The frame id.
    fn frame(&self) -> &str;
}

impl Header for Header1 {
    fn stamp(&self) -> f64 {
        f64::from(self.secs) + f64::from(self.nsecs) * 1e-9
    }
    fn frame(&self) -> &str {
        &self.frame_id
    }
}

impl Header for Header2 {
    fn stamp(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
    fn frame(&self) -> &str {
        &self.frame_id
    }
}

impl Header1 {
    /// A header stamped `secs`, `nsecs` in `frame` (sequence 0).
    pub fn new(secs: u32, nsecs: u32, frame: &str) -> Self {
        Header1 { seq: 0, secs, nsecs, frame_id: frame.to_string() }
    }
}

impl From<&Header1> for Header2 {
    fn from(h: &Header1) -> Self {
        // a ROS 1 stamp past 2038 does not fit ROS 2's i32 seconds: kept as its bits
        Header2 { sec: h.secs as i32, nanosec: h.nsecs, frame_id: h.frame_id.clone() }
    }
}

/// `geometry_msgs/Vector3` (and `Point`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vec3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Vec3 {
    /// As an array.
    pub fn array(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
}

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quat {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

/// `geometry_msgs/TransformStamped`: the child frame in the header's frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped<H> {
    /// The header (its frame is the parent).
    pub header: H,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's origin in the parent frame, m.
    pub translation: Vec3,
    /// The child's axes in the parent frame.
    pub rotation: Quat,
}

/// `tf2_msgs/TFMessage`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TfMessage<H> {
    /// The transforms.
    pub transforms: Vec<TransformStamped<H>>,
}

/// `sensor_msgs/Imu`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Imu<H> {
    /// The header.
    pub header: H,
    orientation: Quat,
    orientation_covariance: [f64; 9],
    /// Angular velocity, rad/s, in the header's frame.
    pub angular_velocity: Vec3,
    /// Its covariance, (rad/s)², row-major.
    pub angular_velocity_covariance: [f64; 9],
    /// Specific force (gravity's reaction included), m/s².
    pub linear_acceleration: Vec3,
    /// Its covariance, (m/s²)², row-major.
    pub linear_acceleration_covariance: [f64; 9],
}

/// `sensor_msgs/NavSatStatus`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NavSatStatus {
    /// −1 no fix, 0 fix, 1 SBAS, 2 GBAS.
    pub status: i8,
    service: u16,
}

/// `sensor_msgs/NavSatFix`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NavSatFix<H> {
    /// The header.
    pub header: H,
    /// The fix's status.
    pub status: NavSatStatus,
    /// Latitude, deg.
    pub latitude: f64,
    /// Longitude, deg.
    pub longitude: f64,
    /// Height above the WGS-84 ellipsoid, m.
    pub altitude: f64,
    /// East, north, up covariance, m², row-major.
    pub position_covariance: [f64; 9],
    /// 0 unknown, 1 approximated, 2 diagonal known, 3 known.
    pub position_covariance_type: u8,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    position: Vec3,
    orientation: Quat,
    covariance: [[f64; 6]; 6],
}

/// `geometry_msgs/TwistWithCovariance`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// Linear velocity, m/s, in the child frame.
    pub linear: Vec3,
    /// Angular velocity, rad/s.
    pub angular: Vec3,
    covariance: [[f64; 6]; 6],
}

/// `nav_msgs/Odometry`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry<H> {
    /// The header (the pose's frame).
    pub header: H,
    /// The twist's frame.
    pub child_frame_id: String,
    pose: PoseWithCovariance,
    /// The body's velocity in `child_frame_id`.
    pub twist: TwistWithCovariance,
}

/// The message types a run reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `sensor_msgs/Imu`.
    Imu,
    /// `sensor_msgs/NavSatFix`.
    NavSatFix,
    /// `nav_msgs/Odometry`.
    Odometry,
    /// `tf2_msgs/TFMessage` (read on `/tf_static`).
    Tf,
}

impl Kind {
    /// The kind of a type name, ROS 1 (`sensor_msgs/Imu`) or ROS 2 (`sensor_msgs/msg/Imu`).
    pub fn of(type_name: &str) -> Option<Kind> {
        match type_name.replace("/msg/", "/").as_str() {
            "sensor_msgs/Imu" => Some(Kind::Imu),
            "sensor_msgs/NavSatFix" => Some(Kind::NavSatFix),
            "nav_msgs/Odometry" => Some(Kind::Odometry),
            "tf2_msgs/TFMessage" => Some(Kind::Tf),
            _ => None,
        }
    }

    /// The ROS 1 type name.
    pub fn ros1_name(self) -> &'static str {
        match self {
            Kind::Imu => "sensor_msgs/Imu",
            Kind::NavSatFix => "sensor_msgs/NavSatFix",
            Kind::Odometry => "nav_msgs/Odometry",
            Kind::Tf => "tf2_msgs/TFMessage",
        }
    }
}

/// Decode one message of type `T` (with ROS 1 or ROS 2 header as the encoding has it).
/// The whole of `data` must be used: a message of another type or a truncated one is an
/// error, not a silently wrong value.
pub fn decode<T: DeserializeOwned + Serialize>(
    data: &[u8],
    encoding: Encoding,
) -> Result<T, String> {
    match encoding {
        Encoding::Ros1 => {
            let mut de = serde_rosmsg::de::Deserializer::new(data, data.len() as u32);
            let value = T::deserialize(&mut de).map_err(|e| e.to_string())?;
            if !de.is_fully_read() {
                return Err("longer than the message type (another type on this topic?)".into());
            }
            Ok(value)
        }
        Encoding::Cdr => {
            let value: T = cdr::deserialize(data).map_err(|e| e.to_string())?;
            // CDR pads the end to 4 bytes at most; more left over is another type
            let used = cdr::calc_serialized_size(&value) as usize;
            if data.len() > used + 3 {
                return Err(format!(
                    "{} bytes where the message type has {used} (another type on this topic?)",
                    data.len()
                ));
            }
            Ok(value)
        }
    }
}

/// Encode a message (the inverse of [`decode`]).
pub fn encode<T: Serialize>(value: &T, encoding: Encoding) -> Result<Vec<u8>, String> {
    match encoding {
        Encoding::Ros1 => {
            // serde_rosmsg writes the message's length first; a bag's record has none
            let mut v = serde_rosmsg::to_vec(value).map_err(|e| e.to_string())?;
            v.drain(..4);
            Ok(v)
        }
        Encoding::Cdr => {
            cdr::serialize::<_, _, cdr::CdrLe>(value, cdr::Infinite).map_err(|e| e.to_string())
        }
    }
}

/// A ROS 1 message as ROS 2's (the header's sequence number dropped).
pub fn imu_to_ros2(m: &Imu<Header1>) -> Imu<Header2> {
    Imu {
        header: (&m.header).into(),
        orientation: m.orientation,
        orientation_covariance: m.orientation_covariance,
        angular_velocity: m.angular_velocity,
        angular_velocity_covariance: m.angular_velocity_covariance,
        linear_acceleration: m.linear_acceleration,
        linear_acceleration_covariance: m.linear_acceleration_covariance,
    }
}

/// A ROS 1 `NavSatFix` as ROS 2's.
pub fn fix_to_ros2(m: &NavSatFix<Header1>) -> NavSatFix<Header2> {
    NavSatFix {
        header: (&m.header).into(),
        status: m.status,
        latitude: m.latitude,
        longitude: m.longitude,
        altitude: m.altitude,
        position_covariance: m.position_covariance,
        position_covariance_type: m.position_covariance_type,
    }
}

/// A ROS 1 `Odometry` as ROS 2's.
pub fn odometry_to_ros2(m: &Odometry<Header1>) -> Odometry<Header2> {
    Odometry {
        header: (&m.header).into(),
        child_frame_id: m.child_frame_id.clone(),
        pose: m.pose.clone(),
        twist: m.twist.clone(),
    }
}

/// A ROS 1 `TFMessage` as ROS 2's.
pub fn tf_to_ros2(m: &TfMessage<Header1>) -> TfMessage<Header2> {
    TfMessage {
        transforms: m
            .transforms
            .iter()
            .map(|t| TransformStamped {
                header: (&t.header).into(),
                child_frame_id: t.child_frame_id.clone(),
                translation: t.translation,
                rotation: t.rotation,
            })
            .collect(),
    }
}

/// ROS 2 message definitions (`ros2msg`) of the three types, for an MCAP's schemas.
pub fn ros2_definition(kind: Kind) -> &'static str {
    match kind {
        Kind::Imu => concat!(
            "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n",
            "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n",
            "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n",
            "float64[9] linear_acceleration_covariance\n",
            "================================================================================\n",
            "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
            "================================================================================\n",
            "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
        ),
        Kind::NavSatFix => concat!(
            "std_msgs/Header header\nsensor_msgs/NavSatStatus status\nfloat64 latitude\n",
            "float64 longitude\nfloat64 altitude\nfloat64[9] position_covariance\n",
            "uint8 position_covariance_type\n",
            "================================================================================\n",
            "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
            "================================================================================\n",
            "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
            "================================================================================\n",
            "MSG: sensor_msgs/NavSatStatus\nint8 status\nuint16 service\n",
        ),
        Kind::Odometry => concat!(
            "std_msgs/Header header\nstring child_frame_id\n",
            "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
            "================================================================================\n",
            "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
            "================================================================================\n",
            "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
            "================================================================================\n",
            "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\n",
            "float64[36] covariance\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\n",
            "geometry_msgs/Quaternion orientation\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
            "================================================================================\n",
            "MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\n",
            "float64[36] covariance\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\n",
            "geometry_msgs/Vector3 angular\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
        ),
        Kind::Tf => concat!(
            "geometry_msgs/TransformStamped[] transforms\n",
            "================================================================================\n",
            "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\n",
            "string child_frame_id\ngeometry_msgs/Transform transform\n",
            "================================================================================\n",
            "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
            "================================================================================\n",
            "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\n",
            "geometry_msgs/Quaternion rotation\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
            "================================================================================\n",
            "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
        ),
    }
}
