//! The channels the live view advertises: the run log's JSON channels
//! ([`crate::log::mcap::JsonChannel`]), so a Foxglove layout made live reads an MCAP file too.

use super::protocol::Channel;
use crate::log::mcap::{
    JsonChannel, COMMAND_CHANNEL, EVENT_CHANNEL, MODEL_CHANNEL, SAMPLE_CHANNEL, STATUS_CHANNEL,
};

/// A live channel (advertised id = index + 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LiveChannel {
    /// Physical samples (`/rover_power/sample`).
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
    pub fn json(self) -> JsonChannel {
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
        Self::ALL.into_iter().find(|c| c.json().topic == topic)
    }

    /// This channel's bit in a subscription mask.
    pub fn bit(self) -> u32 {
        1 << self.index()
    }

    /// The `advertise` entry.
    pub fn advertised(self) -> Channel {
        let json = self.json();
        Channel {
            id: self.id(),
            topic: json.topic.to_owned(),
            encoding: "json".to_owned(),
            schema_name: json.schema_name.to_owned(),
            schema: json.schema.to_owned(),
            schema_encoding: Some("jsonschema".to_owned()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::LiveChannel;
    use serde_json::Value;

    #[test]
    fn ids_topics_and_bits_round_trip() {
        let mut mask = 0;
        for (i, c) in LiveChannel::ALL.into_iter().enumerate() {
            assert_eq!(c.index(), i);
            assert_eq!(LiveChannel::from_id(c.id()), Some(c));
            assert_eq!(LiveChannel::from_topic(c.json().topic), Some(c));
            assert_eq!(mask & c.bit(), 0);
            mask |= c.bit();
            // The schema is the MCAP file's and valid JSON.
            let schema: serde_json::Value =
                serde_json::from_str(c.json().schema).expect("schema is JSON");
            assert_eq!(schema["title"], c.json().schema_name);
            // Foxglove Studio's reader takes it (over the WebSocket as in a file).
            let mut problems = Vec::new();
            crate::log::mcap::studio::schema_problems(&schema, c.json().schema_name, &mut problems);
            assert!(problems.is_empty(), "{problems:?}");
        }
        assert_eq!(LiveChannel::from_id(0), None);
        assert_eq!(LiveChannel::from_id(LiveChannel::COUNT as u32 + 1), None);
    }

    /// The schema node a field path (`left.power_w`) names (nested objects are inline).
    fn field<'a>(node: &'a Value, path: &str) -> Option<&'a Value> {
        path.split('.')
            .try_fold(node, |node, name| node["properties"].get(name))
    }

    #[test]
    fn the_foxglove_layout_plots_numbers_the_channels_schemas_define() {
        let layout: Value =
            serde_json::from_str(include_str!("../../../foxglove/rover-power.json"))
                .expect("layout is JSON");
        let panels = layout["configById"].as_object().expect("panels");
        let mut plotted = 0;
        for (id, config) in panels {
            if id.starts_with("RosOut!") {
                assert_eq!(config["topicToRender"], LiveChannel::Event.json().topic);
                continue;
            }
            assert!(id.starts_with("Plot!"), "{id}");
            for path in config["paths"].as_array().expect("paths") {
                let value = path["value"].as_str().expect("path");
                let (topic, fields) = value.split_once('.').expect("topic.field");
                let channel = LiveChannel::from_topic(topic).expect(value);
                let schema: Value = serde_json::from_str(channel.json().schema).expect("schema");
                let node = field(&schema, fields).unwrap_or_else(|| panic!("{value}"));
                let kind = node["type"].as_str();
                assert!(
                    matches!(kind, Some("number" | "integer")),
                    "{value}: {kind:?}"
                );
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
