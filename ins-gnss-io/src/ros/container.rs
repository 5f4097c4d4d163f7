//! The files: a ROS 1 bag or an MCAP file, told apart by their first bytes, and every
//! message of either in file order.

use super::*;

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
    // the first bytes tell the layout, and hold a bag's header
    let (head, len) = {
        use std::io::Read;
        let io = |e: std::io::Error| file_error(path, e.to_string());
        let f = std::fs::File::open(path).map_err(io)?;
        let len = f.metadata().map_err(io)?.len();
        let mut head = Vec::with_capacity(4096);
        f.take(4096).read_to_end(&mut head).map_err(io)?;
        (head, len)
    };
    let Some(container) = Container::detect(&head) else {
        return Err(file_error(
            path,
            "neither a ROS 1 bag (`#ROSBAG V2.0`) nor an MCAP file (`\\x89MCAP0`)".into(),
        ));
    };
    match container {
        Container::Bag => {
            check_bag_index(path, &head, len)?;
            bag_messages(path, &mut each)?;
        }
        Container::Mcap => mcap_messages(path, &mut each)?,
    }
    Ok(container)
}

/// [`for_each_message`] on a ROS 1 bag.
fn bag_messages(
    path: &Path,
    each: &mut impl FnMut(&Channel, usize, u64, &[u8]) -> Result<(), LineError>,
) -> Result<(), LineError> {
    let mut index = 0usize;
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
    Ok(())
}

/// [`for_each_message`] on an MCAP file.
fn mcap_messages(
    path: &Path,
    each: &mut impl FnMut(&Channel, usize, u64, &[u8]) -> Result<(), LineError>,
) -> Result<(), LineError> {
    let mut index = 0usize;
    let bytes = std::fs::read(path).map_err(|e| file_error(path, e.to_string()))?;
    let stream = mcap::MessageStream::new(&bytes).map_err(|e| file_error(path, e.to_string()))?;
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
    Ok(())
}

/// A bag's header names where its index starts; a bag whose recording did not finish (a
/// `.bag.active`, or one cut short) has none, or one past its end. `rosbag` indexes past
/// the end of the file then, so the header — in `head`, the file's first bytes; `len` is
/// its length — is checked first.
fn check_bag_index(path: &Path, head: &[u8], len: u64) -> Result<(), LineError> {
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
