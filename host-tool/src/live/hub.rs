//! The viewers' registry and the publishing path. Publishing never waits: each viewer has a
//! bounded queue; a message that does not fit is dropped for that viewer and counted, so a
//! slow or vanished viewer costs the recorder nothing.

use super::channels::LiveChannel;
use std::collections::VecDeque;
use std::fmt;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicI64, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

/// A message on its way to a viewer (the payload shared by all viewers).
#[derive(Debug, Clone)]
pub(super) struct Outgoing {
    pub(super) channel: LiveChannel,
    pub(super) timestamp_ns: u64,
    pub(super) payload: Arc<[u8]>,
}

/// Counters of one viewer, shared by the publisher and the viewer's thread.
#[derive(Debug, Default)]
pub(super) struct ViewerCounters {
    /// Bit mask of the subscribed channels ([`LiveChannel::bit`]).
    pub(super) subscribed: AtomicU32,
    /// Messages handed to the viewer's WebSocket.
    pub(super) sent: AtomicU64,
    /// Messages dropped because the viewer's queue was full.
    pub(super) dropped: AtomicU64,
    /// Messages in the queue now (the viewer's thread counts down as it takes them).
    pub(super) queued: AtomicI64,
}

/// What one viewer got, for the summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ViewerReport {
    /// The viewer's address.
    pub peer: SocketAddr,
    /// Messages sent to it.
    pub sent: u64,
    /// Messages dropped for it (its queue was full: it read too slowly or not at all).
    pub dropped: u64,
    /// Why it left (`None`: still connected).
    pub ended: Option<String>,
}

impl fmt::Display for ViewerReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "viewer {}: {} messages sent, {} dropped",
            self.peer, self.sent, self.dropped
        )?;
        if let Some(why) = &self.ended {
            write!(f, " ({why})")?;
        }
        Ok(())
    }
}

struct Slot {
    peer: SocketAddr,
    queue: SyncSender<Outgoing>,
    counters: Arc<ViewerCounters>,
}

/// Most latched messages kept (the stream's events; a damaged stream may have many).
const LATCHED_MAX: usize = 1024;

/// Viewers connected now and those that left.
#[derive(Default)]
pub(super) struct Hub {
    slots: Mutex<Vec<Slot>>,
    left: Mutex<Vec<ViewerReport>>,
    /// Messages offered to [`Hub::publish`] with at least one subscriber.
    published: AtomicU64,
    /// The messages of the latched channels ([`LiveChannel::latched`]) so far, oldest first;
    /// taken with `slots` held, after it.
    latched: Mutex<VecDeque<Outgoing>>,
}

impl fmt::Debug for Hub {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Hub")
            .field("viewers", &self.reports().len())
            .finish_non_exhaustive()
    }
}

/// Locks without panicking: a viewer thread that panicked leaves the list usable.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Hub {
    /// Adds a viewer with a queue of `queue_len` messages; returns its end of the queue.
    pub(super) fn join(
        &self,
        peer: SocketAddr,
        queue_len: usize,
        counters: Arc<ViewerCounters>,
    ) -> Receiver<Outgoing> {
        let (queue, rx) = std::sync::mpsc::sync_channel(queue_len.max(1));
        lock(&self.slots).push(Slot {
            peer,
            queue,
            counters,
        });
        rx
    }

    /// Removes a viewer, keeping its report.
    pub(super) fn leave(&self, counters: &Arc<ViewerCounters>, why: String) {
        let mut slots = lock(&self.slots);
        if let Some(i) = slots
            .iter()
            .position(|s| Arc::ptr_eq(&s.counters, counters))
        {
            let slot = slots.swap_remove(i);
            let mut report = report_of(&slot);
            report.ended = Some(why);
            lock(&self.left).push(report);
        }
    }

    /// Reports a connection that never became a viewer.
    pub(super) fn refused(&self, peer: SocketAddr, why: String) {
        lock(&self.left).push(ViewerReport {
            peer,
            sent: 0,
            dropped: 0,
            ended: Some(why),
        });
    }

    /// Number of viewers connected now.
    pub(super) fn viewers(&self) -> usize {
        lock(&self.slots).len()
    }

    /// Union of the viewers' subscriptions (bit mask).
    pub(super) fn subscribed(&self) -> u32 {
        lock(&self.slots)
            .iter()
            .fold(0, |m, s| m | s.counters.subscribed.load(Ordering::Relaxed))
    }

    /// Sets a viewer's subscriptions to `mask` and returns the messages published so far on
    /// the latched channels it has just subscribed to, oldest first. The publisher holds the
    /// same lock, so each such message reaches the viewer once: here, or through its queue.
    pub(super) fn subscribe(&self, counters: &ViewerCounters, mask: u32) -> Vec<Outgoing> {
        let _slots = lock(&self.slots);
        let new = mask & !counters.subscribed.swap(mask, Ordering::Relaxed);
        lock(&self.latched)
            .iter()
            .filter(|m| m.channel.bit() & new != 0)
            .cloned()
            .collect()
    }

    /// Offers a message to every viewer subscribed to its channel, and keeps it for later
    /// subscribers when its channel is latched; never blocks.
    pub(super) fn publish(&self, message: Outgoing) {
        let bit = message.channel.bit();
        let slots = lock(&self.slots);
        if message.channel.latched() {
            let mut latched = lock(&self.latched);
            if latched.len() == LATCHED_MAX {
                latched.pop_front();
            }
            latched.push_back(message.clone());
        }
        let mut offered = false;
        for slot in slots.iter() {
            if slot.counters.subscribed.load(Ordering::Relaxed) & bit == 0 {
                continue;
            }
            offered = true;
            match slot.queue.try_send(message.clone()) {
                Ok(()) => {
                    slot.counters.queued.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Full(_)) => {
                    slot.counters.dropped.fetch_add(1, Ordering::Relaxed);
                }
                // Its thread is ending; `leave` removes it.
                Err(TrySendError::Disconnected(_)) => {}
            }
        }
        if offered {
            self.published.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// True when no viewer has a message waiting in its queue.
    pub(super) fn queues_empty(&self) -> bool {
        lock(&self.slots)
            .iter()
            .all(|s| s.counters.queued.load(Ordering::Relaxed) <= 0)
    }

    /// Messages published to at least one subscriber.
    pub(super) fn published(&self) -> u64 {
        self.published.load(Ordering::Relaxed)
    }

    /// Every viewer, those that left first.
    pub(super) fn reports(&self) -> Vec<ViewerReport> {
        let mut all = lock(&self.left).clone();
        all.extend(lock(&self.slots).iter().map(report_of));
        all
    }
}

fn report_of(slot: &Slot) -> ViewerReport {
    ViewerReport {
        peer: slot.peer,
        sent: slot.counters.sent.load(Ordering::Relaxed),
        dropped: slot.counters.dropped.load(Ordering::Relaxed),
        ended: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(channel: LiveChannel) -> Outgoing {
        Outgoing {
            channel,
            timestamp_ns: 1,
            payload: Arc::from(&b"{}"[..]),
        }
    }

    #[test]
    fn a_full_queue_drops_and_counts_without_blocking_and_only_subscribers_get_messages() {
        let hub = Hub::default();
        let peer: SocketAddr = "127.0.0.1:1".parse().expect("addr");
        let slow = Arc::new(ViewerCounters::default());
        slow.subscribed
            .store(LiveChannel::Sample.bit(), Ordering::Relaxed);
        let rx = hub.join(peer, 3, slow.clone());
        let idle = Arc::new(ViewerCounters::default());
        let idle_rx = hub.join(peer, 3, idle.clone());
        for _ in 0..10 {
            hub.publish(message(LiveChannel::Sample));
        }
        hub.publish(message(LiveChannel::Model));
        assert_eq!(rx.try_iter().count(), 3);
        assert_eq!(slow.dropped.load(Ordering::Relaxed), 7);
        assert_eq!(idle_rx.try_iter().count(), 0);
        assert_eq!(idle.dropped.load(Ordering::Relaxed), 0);
        assert_eq!(hub.published(), 10);
        assert_eq!(hub.subscribed(), LiveChannel::Sample.bit());
        hub.leave(&slow, "gone".into());
        assert_eq!(hub.viewers(), 1);
        let reports = hub.reports();
        assert_eq!(reports[0].dropped, 7);
        assert_eq!(reports[0].ended.as_deref(), Some("gone"));
    }

    /// A viewer subscribing to the event channel late gets the events published before, once;
    /// the later ones through its queue; a channel that is not latched gives no backlog.
    #[test]
    fn a_late_subscriber_gets_the_latched_events_once() {
        let hub = Hub::default();
        let peer: SocketAddr = "127.0.0.1:1".parse().expect("addr");
        let viewer = Arc::new(ViewerCounters::default());
        let rx = hub.join(peer, 16, viewer.clone());
        hub.publish(message(LiveChannel::Event));
        hub.publish(message(LiveChannel::Sample));
        hub.publish(message(LiveChannel::Event));
        let samples = LiveChannel::Sample.bit();
        assert!(
            hub.subscribe(&viewer, samples).is_empty(),
            "samples are not latched"
        );
        let backlog = hub.subscribe(&viewer, samples | LiveChannel::Event.bit());
        assert_eq!(backlog.len(), 2);
        assert!(backlog.iter().all(|m| m.channel == LiveChannel::Event));
        assert!(hub
            .subscribe(&viewer, samples | LiveChannel::Event.bit())
            .is_empty());
        hub.publish(message(LiveChannel::Event));
        assert_eq!(
            rx.try_iter().count(),
            1,
            "the later event through the queue"
        );
        for _ in 0..LATCHED_MAX + 5 {
            hub.publish(message(LiveChannel::Event));
        }
        let other = Arc::new(ViewerCounters::default());
        let _other_rx = hub.join(peer, 16, other.clone());
        assert_eq!(
            hub.subscribe(&other, LiveChannel::Event.bit()).len(),
            LATCHED_MAX
        );
    }
}
