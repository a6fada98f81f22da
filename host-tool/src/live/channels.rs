//! The channels the live view advertises: the run log's channels
//! ([`crate::log::mcap::LogChannel`]), so a Foxglove layout made live reads an MCAP file too;
//! only the samples differ (one a message here, batched in a file), so a layout does not plot them.

use super::protocol::Channel;
use crate::log::mcap::{
    Encoding, LogChannel, COMMAND_CHANNEL, EVENT_CHANNEL, MODEL_CHANNEL, SAMPLE_CHANNEL,
    STATUS_CHANNEL,
};

/// A live channel (advertised id = index + 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LiveChannel {
    /// Physical samples, one a message (`/rover_power/sample`; a log file batches them on
    /// `/rover_power/sample_batch`).
    Sample,
    /// The board's model frames: power, energy, τ ∝ P/ω per side (`/rover_power/model`).
    Model,
    /// The board's health counters (`/rover_power/status`).
    Status,
    /// Commanded side speeds (`/rover_power/command`).
    Command,
    /// Stream events as `foxglove.Log` lines (`/rover_power/event`).
    Event,
}

impl LiveChannel {
    /// Number of channels.
    pub const COUNT: usize = 5;
    /// Every channel, in id order.
    pub const ALL: [LiveChannel; Self::COUNT] = [
        LiveChannel::Sample,
        LiveChannel::Model,
        LiveChannel::Status,
        LiveChannel::Command,
        LiveChannel::Event,
    ];

    /// Whether a viewer that subscribes late still gets what was published before (as a
    /// latched ROS topic does): the stream's events, which are few and say what the stream is
    /// (started, wall clock, device lost). A viewer subscribes panel by panel, and its event
    /// panel would otherwise miss the run's first lines.
    pub fn latched(self) -> bool {
        self == LiveChannel::Event
    }

    /// The run log's declaration of this channel.
    pub fn log_channel(self) -> LogChannel {
        match self {
            LiveChannel::Sample => SAMPLE_CHANNEL,
            LiveChannel::Model => MODEL_CHANNEL,
            LiveChannel::Status => STATUS_CHANNEL,
            LiveChannel::Command => COMMAND_CHANNEL,
            LiveChannel::Event => EVENT_CHANNEL,
        }
    }

    /// Index in [`LiveChannel::ALL`].
    pub fn index(self) -> usize {
        match self {
            LiveChannel::Sample => 0,
            LiveChannel::Model => 1,
            LiveChannel::Status => 2,
            LiveChannel::Command => 3,
            LiveChannel::Event => 4,
        }
    }

    /// The advertised channel id (ids start at 1).
    pub fn id(self) -> u32 {
        self.index() as u32 + 1
    }

    /// The channel advertised as `id`.
    pub fn from_id(id: u32) -> Option<Self> {
        let index = usize::try_from(id.checked_sub(1)?).ok()?;
        Self::ALL.get(index).copied()
    }

    /// The channel of `topic`.
    pub fn from_topic(topic: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|c| c.log_channel().topic == topic)
    }

    /// This channel's bit in a subscription mask.
    pub fn bit(self) -> u32 {
        1 << self.index()
    }

    /// The `advertise` entry: a JSON schema as text, a protobuf descriptor set in base64 (as
    /// the protocol asks for binary schemas).
    pub fn advertised(self) -> Channel {
        let declared = self.log_channel();
        let schema = match declared.encoding {
            Encoding::Json(schema) => schema.to_owned(),
            Encoding::Protobuf => data_encoding::BASE64.encode(&declared.schema()),
        };
        Channel {
            id: self.id(),
            topic: declared.topic.to_owned(),
            encoding: declared.message_encoding().to_owned(),
            schema_name: declared.schema_name.to_owned(),
            schema,
            schema_encoding: Some(declared.schema_encoding().to_owned()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Encoding, LiveChannel};
    use serde_json::Value;

    #[test]
    fn ids_topics_and_bits_round_trip() {
        let mut mask = 0;
        for (i, c) in LiveChannel::ALL.into_iter().enumerate() {
            assert_eq!(c.index(), i);
            assert_eq!(LiveChannel::from_id(c.id()), Some(c));
            let declared = c.log_channel();
            assert_eq!(LiveChannel::from_topic(declared.topic), Some(c));
            assert_eq!(mask & c.bit(), 0);
            mask |= c.bit();
            let advertised = c.advertised();
            match declared.encoding {
                // The schema is the MCAP file's, valid JSON that Foxglove Studio's reader takes
                // (over the WebSocket as in a file).
                Encoding::Json(text) => {
                    let schema: Value = serde_json::from_str(text).expect("schema is JSON");
                    assert_eq!(schema["title"], declared.schema_name);
                    let mut problems = Vec::new();
                    crate::log::mcap::studio::schema_problems(
                        &schema,
                        declared.schema_name,
                        &mut problems,
                    );
                    assert!(problems.is_empty(), "{problems:?}");
                    assert_eq!(advertised.schema, text);
                }
                // The descriptor set, in base64 as the protocol carries binary schemas.
                Encoding::Protobuf => {
                    let bytes = data_encoding::BASE64
                        .decode(advertised.schema.as_bytes())
                        .expect("base64");
                    assert_eq!(bytes, declared.schema());
                    assert_eq!(advertised.encoding, "protobuf");
                }
            }
        }
        assert_eq!(LiveChannel::from_id(0), None);
        assert_eq!(LiveChannel::from_id(LiveChannel::COUNT as u32 + 1), None);
    }

    /// The schema node a field path (`left.power_w`) names (nested objects are inline).
    fn field<'a>(node: &'a Value, path: &str) -> Option<&'a Value> {
        path.split('.')
            .try_fold(node, |node, name| node["properties"].get(name))
    }

    /// Every path of the layout names a number field of a channel that the live view advertises
    /// and a log file declares with the same schema, so one layout draws a file and the live
    /// view alike (a file's samples are batched on another topic: live only, never in a path).
    #[test]
    fn the_foxglove_layout_plots_numbers_the_channels_schemas_define() {
        let layout: Value =
            serde_json::from_str(include_str!("../../../foxglove/rover-power.json"))
                .expect("layout is JSON");
        let panels = layout["configById"].as_object().expect("panels");
        // The channels of a log file as the recorder writes it.
        let (run, _) = crate::log::mcap::tests::sim_run(200);
        let file = crate::log::mcap::write_mcap_run(std::io::Cursor::new(Vec::new()), &run)
            .expect("written")
            .into_inner();
        let summary = ::mcap::Summary::read(&file)
            .expect("MCAP")
            .expect("summary");
        let in_file = |topic: &str, schema_name: &str| {
            summary.channels.values().any(|c| {
                c.topic == topic && c.schema.as_ref().is_some_and(|s| s.name == schema_name)
            })
        };
        let mut plotted = 0;
        for (id, config) in panels {
            if id.starts_with("RosOut!") {
                let declared = LiveChannel::Event.log_channel();
                assert_eq!(config["topicToRender"], declared.topic);
                assert!(in_file(declared.topic, declared.schema_name));
                continue;
            }
            assert!(id.starts_with("Plot!"), "{id}");
            for path in config["paths"].as_array().expect("paths") {
                let value = path["value"].as_str().expect("path");
                let (topic, fields) = value.split_once('.').expect("topic.field");
                let channel = LiveChannel::from_topic(topic).expect(value);
                let declared = channel.log_channel();
                assert!(
                    in_file(declared.topic, declared.schema_name),
                    "{value}: not a channel of a log file"
                );
                match declared.encoding {
                    Encoding::Json(text) => {
                        let schema: Value = serde_json::from_str(text).expect("schema");
                        let node = field(&schema, fields).unwrap_or_else(|| panic!("{value}"));
                        let kind = node["type"].as_str();
                        assert!(
                            matches!(kind, Some("number" | "integer")),
                            "{value}: {kind:?}"
                        );
                    }
                    Encoding::Protobuf => assert!(
                        crate::log::mcap::proto::is_number(declared.schema_name, fields),
                        "{value}"
                    ),
                }
                plotted += 1;
            }
        }
        // Power ×2, energy ×3, τ ×2, eight counters.
        assert_eq!(plotted, 15);
        // The panels named in the layout tree are the configured ones.
        let tree = layout["layout"].to_string();
        for id in panels.keys() {
            assert!(tree.contains(&format!("\"{id}\"")), "{id} not placed");
        }
    }
}
