//! The subset of Foxglove's WebSocket protocol (`foxglove.websocket.v1`) the live view speaks:
//! the server's `serverInfo`, `advertise` and `status` text ops, the client's `subscribe` and
//! `unsubscribe`, and binary message data frames. Nothing that would let a viewer act on the
//! board (client publish, services, parameters) is offered.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The WebSocket subprotocol both ends must name in the handshake.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";

/// Opcode of a binary message data frame (server → client).
pub const OP_MESSAGE_DATA: u8 = 0x01;

/// Bytes before the payload of a message data frame: opcode, subscription id (u32 LE),
/// timestamp (u64 LE, ns).
pub const MESSAGE_DATA_HEADER: usize = 1 + 4 + 8;

/// A text op from the server.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
pub enum ServerOp {
    /// The first message of a connection: who the server is and what it can do.
    #[serde(rename_all = "camelCase")]
    ServerInfo {
        /// Server name.
        name: String,
        /// Optional features; this server has none (no client publish, services, parameters,
        /// time).
        capabilities: Vec<String>,
        /// Encodings a client may publish in (none: viewers only watch).
        #[serde(default)]
        supported_encodings: Vec<String>,
        /// Free-form key/value pairs.
        #[serde(default)]
        metadata: BTreeMap<String, String>,
        /// Changes when the server restarts (a viewer then drops its cached state).
        #[serde(default)]
        session_id: Option<String>,
    },
    /// Channels a client may subscribe to.
    Advertise {
        /// The channels.
        channels: Vec<Channel>,
    },
    /// A note for the viewer's problems panel.
    Status {
        /// 0 info, 1 warning, 2 error.
        level: u8,
        /// What happened.
        message: String,
    },
}

/// Status levels of [`ServerOp::Status`].
pub mod status_level {
    /// Informational.
    pub const INFO: u8 = 0;
    /// Something the viewer asked for was not done.
    pub const WARNING: u8 = 1;
    /// The viewer cannot be served.
    pub const ERROR: u8 = 2;
}

/// An advertised channel.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Channel {
    /// Server-chosen channel id.
    pub id: u32,
    /// Topic name.
    pub topic: String,
    /// Message encoding (`json`).
    pub encoding: String,
    /// Schema name.
    pub schema_name: String,
    /// The schema itself.
    pub schema: String,
    /// Schema encoding (`jsonschema`).
    #[serde(default)]
    pub schema_encoding: Option<String>,
}

/// A text op from a client.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
pub enum ClientOp {
    /// Start receiving channels, each under a client-chosen subscription id.
    Subscribe {
        /// The new subscriptions.
        subscriptions: Vec<Subscription>,
    },
    /// Stop receiving the given subscriptions.
    #[serde(rename_all = "camelCase")]
    Unsubscribe {
        /// Subscription ids to end.
        subscription_ids: Vec<u32>,
    },
}

/// One subscription of a [`ClientOp::Subscribe`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Subscription {
    /// Client-chosen id; message data frames carry it.
    pub id: u32,
    /// The advertised channel.
    pub channel_id: u32,
}

/// Why a client's text message was not acted on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ClientOpError {
    /// Not a JSON object with an `op`.
    #[error("not a foxglove.websocket.v1 op: {0}")]
    Malformed(String),
    /// A valid op this server does not offer.
    #[error(
        "op {0:?} is not supported: this server only streams the board's data (subscribe, \
         unsubscribe); commanding the board from the viewer is not offered"
    )]
    Unsupported(String),
}

/// Parses a client's text message.
pub fn parse_client_op(text: &str) -> Result<ClientOp, ClientOpError> {
    serde_json::from_str(text).map_err(|e| {
        #[derive(Deserialize)]
        struct AnyOp {
            op: String,
        }
        match serde_json::from_str::<AnyOp>(text) {
            Ok(any) if !matches!(any.op.as_str(), "subscribe" | "unsubscribe") => {
                ClientOpError::Unsupported(any.op)
            }
            _ => ClientOpError::Malformed(e.to_string()),
        }
    })
}

/// A binary message data frame: `0x01`, subscription id (u32 LE), timestamp (u64 LE, ns),
/// payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageData<'a> {
    /// The client's subscription id.
    pub subscription_id: u32,
    /// The message's time stamp [ns since the Unix epoch].
    pub timestamp_ns: u64,
    /// The message (JSON for every channel of this server).
    pub payload: &'a [u8],
}

impl<'a> MessageData<'a> {
    /// The frame's bytes.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(MESSAGE_DATA_HEADER + self.payload.len());
        out.push(OP_MESSAGE_DATA);
        out.extend_from_slice(&self.subscription_id.to_le_bytes());
        out.extend_from_slice(&self.timestamp_ns.to_le_bytes());
        out.extend_from_slice(self.payload);
        out
    }

    /// Reads a frame; `None` if it is not a message data frame (another opcode, too short).
    pub fn decode(bytes: &'a [u8]) -> Option<Self> {
        let (&op, rest) = bytes.split_first()?;
        if op != OP_MESSAGE_DATA || rest.len() < MESSAGE_DATA_HEADER - 1 {
            return None;
        }
        let (id, rest) = rest.split_at(4);
        let (ts, payload) = rest.split_at(8);
        Some(MessageData {
            subscription_id: u32::from_le_bytes(id.try_into().ok()?),
            timestamp_ns: u64::from_le_bytes(ts.try_into().ok()?),
            payload,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_data_has_the_spec_layout_and_reads_back() {
        let frame = MessageData {
            subscription_id: 0x0403_0201,
            timestamp_ns: 0x0c0b_0a09_0807_0605,
            payload: b"{}",
        };
        let bytes = frame.encode();
        assert_eq!(
            bytes,
            [1, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, b'{', b'}']
        );
        assert_eq!(MessageData::decode(&bytes), Some(frame));
        assert_eq!(MessageData::decode(&bytes[..12]), None);
        assert_eq!(MessageData::decode(&[2; 20]), None);
    }

    #[test]
    fn server_ops_are_spelt_as_the_spec() {
        let info = ServerOp::ServerInfo {
            name: "n".into(),
            capabilities: vec![],
            supported_encodings: vec![],
            metadata: BTreeMap::new(),
            session_id: Some("s".into()),
        };
        let json = serde_json::to_value(&info).expect("json");
        assert_eq!(json["op"], "serverInfo");
        assert_eq!(json["sessionId"], "s");
        assert!(json["supportedEncodings"].is_array());
        let advertise = ServerOp::Advertise {
            channels: vec![Channel {
                id: 1,
                topic: "/t".into(),
                encoding: "json".into(),
                schema_name: "x".into(),
                schema: "{}".into(),
                schema_encoding: Some("jsonschema".into()),
            }],
        };
        let json = serde_json::to_value(&advertise).expect("json");
        assert_eq!(json["op"], "advertise");
        assert_eq!(json["channels"][0]["schemaName"], "x");
        assert_eq!(json["channels"][0]["schemaEncoding"], "jsonschema");
    }

    #[test]
    fn client_ops_parse_and_unsupported_ones_are_named() {
        assert_eq!(
            parse_client_op(r#"{"op":"subscribe","subscriptions":[{"id":7,"channelId":1}]}"#),
            Ok(ClientOp::Subscribe {
                subscriptions: vec![Subscription {
                    id: 7,
                    channel_id: 1
                }]
            })
        );
        assert_eq!(
            parse_client_op(r#"{"op":"unsubscribe","subscriptionIds":[7,8]}"#),
            Ok(ClientOp::Unsubscribe {
                subscription_ids: vec![7, 8]
            })
        );
        assert!(matches!(
            parse_client_op(r#"{"op":"clientAdvertise","channels":[]}"#),
            Err(ClientOpError::Unsupported(op)) if op == "clientAdvertise"
        ));
        assert!(matches!(
            parse_client_op(r#"{"op":"subscribe"}"#),
            Err(ClientOpError::Malformed(_))
        ));
        assert!(matches!(
            parse_client_op("not json"),
            Err(ClientOpError::Malformed(_))
        ));
    }
}
