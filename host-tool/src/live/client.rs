//! A minimal `foxglove.websocket.v1` client: what the tests and the bench use as a viewer, and
//! a check that the server speaks the protocol a real viewer expects (handshake subprotocol,
//! `serverInfo` then `advertise`, binary message data).

use super::protocol::{Channel, ClientOp, MessageData, ServerOp, Subscription, SUBPROTOCOL};
use super::LiveError;
use std::net::{SocketAddr, TcpStream};
use std::time::Duration;
use tungstenite::client::IntoClientRequest;
use tungstenite::http::HeaderValue;
use tungstenite::{Message, WebSocket};

/// A message data frame received by [`LiveClient`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    /// The subscription it came under.
    pub subscription_id: u32,
    /// Its time stamp [Unix ns].
    pub timestamp_ns: u64,
    /// Its payload.
    pub payload: Vec<u8>,
}

/// What [`LiveClient::read`] got.
#[derive(Debug, Clone, PartialEq)]
pub enum Incoming {
    /// A binary message data frame.
    Data(Received),
    /// A text op.
    Op(ServerOp),
    /// The server closed the connection, with this close code if its close frame had one.
    Closed(Option<u16>),
}

/// A connected viewer.
#[derive(Debug)]
pub struct LiveClient {
    ws: WebSocket<TcpStream>,
    /// The server's `serverInfo`.
    pub server_info: ServerOp,
    /// The advertised channels.
    pub channels: Vec<Channel>,
}

impl LiveClient {
    /// Connects, checks the negotiated subprotocol and reads `serverInfo` and `advertise`;
    /// every read waits at most `timeout`.
    pub fn connect(addr: SocketAddr, timeout: Duration) -> Result<Self, LiveError> {
        let protocol = |detail: String| LiveError::Protocol(detail);
        let stream = TcpStream::connect_timeout(&addr, timeout).map_err(LiveError::Client)?;
        stream
            .set_read_timeout(Some(timeout))
            .map_err(LiveError::Client)?;
        let mut request = format!("ws://{addr}/")
            .into_client_request()
            .map_err(|e| protocol(e.to_string()))?;
        request.headers_mut().insert(
            "Sec-WebSocket-Protocol",
            HeaderValue::from_static(SUBPROTOCOL),
        );
        let (ws, response) =
            tungstenite::client(request, stream).map_err(|e| protocol(e.to_string()))?;
        let chosen = response
            .headers()
            .get("Sec-WebSocket-Protocol")
            .and_then(|v| v.to_str().ok());
        if chosen != Some(SUBPROTOCOL) {
            return Err(protocol(format!(
                "the server chose subprotocol {chosen:?}, not {SUBPROTOCOL}"
            )));
        }
        let mut client = LiveClient {
            ws,
            server_info: ServerOp::Status {
                level: 0,
                message: String::new(),
            },
            channels: Vec::new(),
        };
        client.server_info = match client.read()? {
            Incoming::Op(info @ ServerOp::ServerInfo { .. }) => info,
            other => {
                return Err(protocol(format!(
                    "expected serverInfo first, got {other:?}"
                )))
            }
        };
        client.channels = match client.read()? {
            Incoming::Op(ServerOp::Advertise { channels }) => channels,
            other => return Err(protocol(format!("expected advertise, got {other:?}"))),
        };
        Ok(client)
    }

    /// The advertised channel of `topic`.
    pub fn channel(&self, topic: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.topic == topic)
    }

    /// Subscribes to `topic` under `subscription_id`.
    pub fn subscribe(&mut self, subscription_id: u32, topic: &str) -> Result<(), LiveError> {
        let channel = self
            .channel(topic)
            .ok_or_else(|| LiveError::Protocol(format!("{topic} is not advertised")))?
            .id;
        self.send(&ClientOp::Subscribe {
            subscriptions: vec![Subscription {
                id: subscription_id,
                channel_id: channel,
            }],
        })
    }

    /// Ends a subscription.
    pub fn unsubscribe(&mut self, subscription_id: u32) -> Result<(), LiveError> {
        self.send(&ClientOp::Unsubscribe {
            subscription_ids: vec![subscription_id],
        })
    }

    /// Sends a text message as is (for tests of ops the server does not offer).
    pub fn send_text(&mut self, text: String) -> Result<(), LiveError> {
        self.ws
            .send(Message::text(text))
            .map_err(|e| LiveError::Protocol(e.to_string()))
    }

    fn send(&mut self, op: &ClientOp) -> Result<(), LiveError> {
        let text = serde_json::to_string(op).map_err(|e| LiveError::Protocol(e.to_string()))?;
        self.send_text(text)
    }

    /// The next frame from the server (waits at most the connect timeout).
    pub fn read(&mut self) -> Result<Incoming, LiveError> {
        loop {
            let message = match self.ws.read() {
                Ok(m) => m,
                Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => {
                    return Ok(Incoming::Closed(None))
                }
                Err(tungstenite::Error::Io(e)) => return Err(LiveError::Client(e)),
                Err(e) => return Err(LiveError::Protocol(e.to_string())),
            };
            return match message {
                Message::Binary(bytes) => {
                    let data = MessageData::decode(&bytes).ok_or_else(|| {
                        LiveError::Protocol(format!(
                            "binary frame is not message data (opcode {:?})",
                            bytes.first()
                        ))
                    })?;
                    Ok(Incoming::Data(Received {
                        subscription_id: data.subscription_id,
                        timestamp_ns: data.timestamp_ns,
                        payload: data.payload.to_vec(),
                    }))
                }
                Message::Text(text) => serde_json::from_str(text.as_str())
                    .map(Incoming::Op)
                    .map_err(|e| LiveError::Protocol(format!("op {text}: {e}"))),
                Message::Close(frame) => Ok(Incoming::Closed(frame.map(|f| u16::from(f.code)))),
                _ => continue,
            };
        }
    }
}
