//! A recording's messages copied into an MCAP file, ROS 1 or ROS 2 CDR.

use super::*;

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

/// The static transforms as one `tf2_msgs/TFMessage` stamped `secs`, `nsecs`.
fn tf_message(static_transforms: &[StaticTransform], secs: u32, nsecs: u32) -> TfMessage<Header1> {
    TfMessage {
        transforms: static_transforms
            .iter()
            .map(|t| TransformStamped {
                header: Header1::new(secs, nsecs, &t.parent),
                child_frame_id: t.child.clone(),
                translation: Vec3 { x: t.translation[0], y: t.translation[1], z: t.translation[2] },
                rotation: Quat {
                    x: t.rotation[0],
                    y: t.rotation[1],
                    z: t.rotation[2],
                    w: t.rotation[3],
                },
            })
            .collect(),
    }
}

/// A channel of the output for an input channel (and its schema): the ROS 1 message as it
/// is, or (CDR) its ROS 2 form (`kind`, the input's message type).
fn add_channel<W: std::io::Write + std::io::Seek>(
    writer: &mut mcap::Writer<W>,
    channel: &Channel,
    kind: Option<Kind>,
    encoding: Encoding,
) -> Result<u16, String> {
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
    let schema =
        writer.add_schema(&name, schema_encoding, &definition).map_err(|e| e.to_string())?;
    let id = writer
        .add_channel(schema, &channel.topic, message_encoding, &BTreeMap::new())
        .map_err(|e| e.to_string())?;
    Ok(id)
}

/// A ROS 1 message of `kind` in its ROS 2 form, CDR-encoded.
fn cdr_of(kind: Kind, data: &[u8]) -> Result<Vec<u8>, String> {
    match kind {
        Kind::Imu => to_cdr(data, msg::imu_to_ros2),
        Kind::NavSatFix => to_cdr(data, msg::fix_to_ros2),
        Kind::Odometry => to_cdr(data, msg::odometry_to_ros2),
        Kind::Tf => to_cdr(data, msg::tf_to_ros2),
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
                converted = cdr_of(kind, data).map_err(bad)?;
                &converted[..]
            }
        };
        let id = match ids.get(&channel.topic) {
            Some(&id) => id,
            None => {
                let id = add_channel(&mut writer, channel, kind, encoding).map_err(out_error)?;
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
            let message = tf_message(static_transforms, secs, nsecs);
            let bytes = encode(&message, Encoding::Ros1).map_err(&out_error)?;
            put(tf_channel, 0, receive_ns, &bytes)?;
        }
        first = false;
        put(channel, index, receive_ns, data)
    })?;
    writer.finish().map_err(|e| out_error(e.to_string()))?;
    Ok((written, left))
}

/// A ROS 1 message `data` of type `M` as the ROS 2 CDR bytes of `convert(message)`.
fn to_cdr<M, N>(data: &[u8], convert: fn(&M) -> N) -> Result<Vec<u8>, String>
where
    M: serde::de::DeserializeOwned + serde::Serialize,
    N: serde::Serialize,
{
    let m: M = decode(data, Encoding::Ros1)?;
    encode(&convert(&m), Encoding::Cdr)
}
