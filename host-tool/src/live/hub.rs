//! The viewers' registry and the publishing path. Publishing never waits: each viewer has a
//! bounded queue; a message that does not fit is dropped for that viewer and counted, so a
//! slow or vanished viewer costs the recorder nothing.

use super::channels::LiveChannel;
use super::LiveOptions;
use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Instant;

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
    /// Most latched messages waiting for it at once, besides its queue (bounded by one
    /// latched history per channel, however often it resubscribes).
    pub(super) backlog_peak: AtomicUsize,
    /// Set when a new viewer takes its place ([`Hub::join`]); its thread then ends.
    pub(super) evicted: AtomicBool,
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

/// Viewers beyond those reported one by one: counted together.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ViewerTally {
    /// How many.
    pub viewers: u64,
    /// Messages sent to them.
    pub sent: u64,
    /// Messages dropped for them.
    pub dropped: u64,
}

struct Slot {
    peer: SocketAddr,
    joined: Instant,
    queue: SyncSender<Outgoing>,
    counters: Arc<ViewerCounters>,
}

/// Most latched messages kept (the stream's events; a damaged stream may have many).
pub(super) const LATCHED_MAX: usize = 1024;
/// Viewers that left reported one by one; later ones are counted ([`ViewerTally`]), so a
/// connection flood costs neither memory nor summary lines.
const LEFT_KEPT: usize = 64;
/// Different reasons for refusing a connection kept apart; the rest are counted as "other".
const REASONS_KEPT: usize = 32;

/// Viewers connected now and those that left.
#[derive(Default)]
pub(super) struct Hub {
    slots: Mutex<Vec<Slot>>,
    left: Mutex<Vec<ViewerReport>>,
    /// Viewers that left after the first [`LEFT_KEPT`].
    left_more: Mutex<ViewerTally>,
    /// Connections that never became viewers, by reason.
    refused: Mutex<BTreeMap<String, u64>>,
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
    /// Adds a viewer with a queue of [`LiveOptions::queue_len`] messages; returns its end of
    /// the queue. With [`LiveOptions::max_viewers`] connected, it takes the place of the one
    /// that has subscribed to nothing the longest (told by [`ViewerCounters::evicted`]: an idle
    /// connection must not lock the viewers out); `Err` (why) when every viewer subscribes.
    pub(super) fn join(
        &self,
        peer: SocketAddr,
        options: &LiveOptions,
        counters: Arc<ViewerCounters>,
    ) -> Result<Receiver<Outgoing>, String> {
        let mut slots = lock(&self.slots);
        let staying = |s: &&Slot| !s.counters.evicted.load(Ordering::Relaxed);
        if slots.iter().filter(staying).count() >= options.max_viewers {
            let idle = slots
                .iter()
                .filter(staying)
                .filter(|s| s.counters.subscribed.load(Ordering::Relaxed) == 0)
                .min_by_key(|s| s.joined)
                .ok_or_else(|| {
                    format!(
                        "{} viewers already, each subscribed: try again later",
                        options.max_viewers
                    )
                })?;
            idle.counters.evicted.store(true, Ordering::Relaxed);
        }
        let (queue, rx) = std::sync::mpsc::sync_channel(options.queue_len.max(1));
        slots.push(Slot {
            peer,
            joined: Instant::now(),
            queue,
            counters,
        });
        Ok(rx)
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
            let mut left = lock(&self.left);
            if left.len() < LEFT_KEPT {
                report.ended = Some(why);
                left.push(report);
            } else {
                let mut more = lock(&self.left_more);
                more.viewers += 1;
                more.sent += report.sent;
                more.dropped += report.dropped;
            }
        }
    }

    /// Counts a connection that never became a viewer.
    pub(super) fn refused(&self, why: String) {
        let mut refused = lock(&self.refused);
        let key = if refused.len() < REASONS_KEPT || refused.contains_key(&why) {
            why
        } else {
            "other reasons".to_owned()
        };
        *refused.entry(key).or_default() += 1;
    }

    /// Connections refused so far, by reason.
    pub(super) fn refusals(&self) -> Vec<(String, u64)> {
        lock(&self.refused)
            .iter()
            .map(|(why, n)| (why.clone(), *n))
            .collect()
    }

    /// Viewers that left beyond those [`Hub::reports`] lists.
    pub(super) fn more_viewers(&self) -> ViewerTally {
        *lock(&self.left_more)
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

    /// The most latched messages each connected viewer has had waiting at once.
    #[cfg(test)]
    pub(super) fn backlog_peaks(&self) -> Vec<usize> {
        lock(&self.slots)
            .iter()
            .map(|s| s.counters.backlog_peak.load(Ordering::Relaxed))
            .collect()
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
        let three = LiveOptions {
            queue_len: 3,
            ..LiveOptions::default()
        };
        let rx = hub.join(peer, &three, slow.clone()).expect("a place");
        let idle = Arc::new(ViewerCounters::default());
        let idle_rx = hub.join(peer, &three, idle.clone()).expect("a place");
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
        let options = LiveOptions {
            queue_len: 16,
            ..LiveOptions::default()
        };
        let rx = hub.join(peer, &options, viewer.clone()).expect("a place");
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
        let _other_rx = hub.join(peer, &options, other.clone()).expect("a place");
        assert_eq!(
            hub.subscribe(&other, LiveChannel::Event.bit()).len(),
            LATCHED_MAX
        );
    }

    /// Idle connections (joined, subscribed to nothing) do not lock a new viewer out: it takes
    /// the place of the oldest idle one; with every viewer subscribed it is refused. A flood of
    /// refusals is counted by reason, not kept one by one.
    #[test]
    fn a_new_viewer_takes_the_place_of_the_oldest_idle_one_and_refusals_are_counted() {
        let hub = Hub::default();
        let peer: SocketAddr = "127.0.0.1:1".parse().expect("addr");
        let two = LiveOptions {
            max_viewers: 2,
            ..LiveOptions::default()
        };
        let busy = Arc::new(ViewerCounters::default());
        let _busy_rx = hub.join(peer, &two, busy.clone()).expect("a place");
        hub.subscribe(&busy, LiveChannel::Sample.bit());
        let idle = Arc::new(ViewerCounters::default());
        let _idle_rx = hub.join(peer, &two, idle.clone()).expect("a place");
        let newcomer = Arc::new(ViewerCounters::default());
        let _new_rx = hub
            .join(peer, &two, newcomer.clone())
            .expect("the idle one's place");
        assert!(idle.evicted.load(Ordering::Relaxed));
        assert!(!busy.evicted.load(Ordering::Relaxed));
        hub.subscribe(&newcomer, LiveChannel::Model.bit());
        let refused = hub.join(peer, &two, Arc::new(ViewerCounters::default()));
        assert!(refused.is_err_and(|why| why.contains("2 viewers already")));
        for _ in 0..1000 {
            hub.refused("refused: busy".into());
        }
        for i in 0..100 {
            hub.refused(format!("handshake failed: {i}"));
        }
        let refusals = hub.refusals();
        assert_eq!(refusals.len(), REASONS_KEPT + 1, "{refusals:?}");
        assert_eq!(refusals.iter().map(|r| r.1).sum::<u64>(), 1100);
        for _ in 0..LEFT_KEPT + 10 {
            let c = Arc::new(ViewerCounters::default());
            let _rx = hub.join(peer, &LiveOptions::default(), c.clone());
            hub.leave(&c, "gone".into());
        }
        assert_eq!(hub.reports().len(), LEFT_KEPT + 3);
        assert_eq!(hub.more_viewers().viewers, 10);
    }
}
