//! The simulator's settings: faults and capacity per kind of link, and timing.

use std::time::Duration;

/// How one kind of link behaves. Probabilities are in `[0, 1]`.
///
/// ```
/// use slate_transport::LinkConfig;
/// use std::time::Duration;
/// // An acoustic-modem-like team link: one shared channel, 32-byte frames.
/// let team = LinkConfig::clean()
///     .delay(Duration::from_secs(1))
///     .bandwidth(80)
///     .loss(0.2)
///     .shared()
///     .frames(32, Duration::from_millis(500));
/// assert_eq!(team.frame_count(100), 4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkConfig {
    /// Propagation delay added to every message.
    pub delay: Duration,
    /// Extra random delay, uniform in `[0, jitter]`, drawn per delivery: it reorders.
    pub jitter: Duration,
    /// Probability that a best-effort delivery (or one attempt of a reliable send) is lost.
    pub loss: f64,
    /// A publication's loss is drawn once per receiving *robot*, and that robot's
    /// endpoints share the outcome: one radio receives for the robot, so its modules
    /// lose or get a frame together. `false`: one draw per receiving endpoint. Only
    /// publications are concerned (a reliable send has one receiver anyway); duplication
    /// and jitter stay per endpoint.
    pub loss_per_robot: bool,
    /// Probability that a best-effort delivery arrives twice.
    pub duplicate: f64,
    /// Capacity of each sender's transmitter on this kind of link, in bit/s (`None`:
    /// unlimited). A message occupies the transmitter for `bytes * 8 / bandwidth` (plus
    /// the frames' overhead); messages queue behind it.
    pub bandwidth: Option<u64>,
    /// One transmitter for every sender on this kind of link: a shared half-duplex
    /// channel (an acoustic modem's). While anyone transmits, every other sender queues,
    /// so nobody receives while it transmits. `false`: a transmitter per sender.
    pub shared: bool,
    /// The largest frame on the air, bytes (`None`: a message is one frame). A longer
    /// message goes as `ceil(len / frame_bytes)` frames, back to back; each is lost
    /// independently with [`loss`](Self::loss), and the message arrives only if every
    /// frame does (a reliable send then retransmits the whole message).
    pub frame_bytes: Option<usize>,
    /// Extra airtime of every frame: preamble, synchronisation, turn-around guard.
    pub frame_overhead: Duration,
    /// The longest a message may wait for its transmitter: one that would wait longer
    /// is dropped by the sender (a modem's transmit queue is finite), so an overloaded
    /// link neither delivers hours late nor holds an ever-growing queue. Counted in
    /// [`Channel::dropped`](crate::Channel::dropped). `None`: it waits as long as it takes.
    pub max_queue: Option<Duration>,
}

impl LinkConfig {
    /// No delay, no faults, no cap.
    pub fn clean() -> Self {
        LinkConfig {
            delay: Duration::ZERO,
            jitter: Duration::ZERO,
            loss: 0.0,
            loss_per_robot: false,
            duplicate: 0.0,
            bandwidth: None,
            shared: false,
            frame_bytes: None,
            frame_overhead: Duration::ZERO,
            max_queue: None,
        }
    }

    /// Sets the delay.
    pub fn delay(mut self, delay: Duration) -> Self {
        self.delay = delay;
        self
    }

    /// Sets the jitter.
    pub fn jitter(mut self, jitter: Duration) -> Self {
        self.jitter = jitter;
        self
    }

    /// Sets the loss probability.
    pub fn loss(mut self, p: f64) -> Self {
        self.loss = p;
        self
    }

    /// Draws a publication's loss once per receiving robot (see
    /// [`loss_per_robot`](Self::loss_per_robot)).
    pub fn loss_per_robot(mut self) -> Self {
        self.loss_per_robot = true;
        self
    }

    /// Sets the duplication probability.
    pub fn duplicate(mut self, p: f64) -> Self {
        self.duplicate = p;
        self
    }

    /// Sets the bandwidth in bit/s.
    pub fn bandwidth(mut self, bits_per_second: u64) -> Self {
        self.bandwidth = Some(bits_per_second.max(1));
        self
    }

    /// Makes the link one shared half-duplex channel (see [`shared`](Self::shared)).
    pub fn shared(mut self) -> Self {
        self.shared = true;
        self
    }

    /// Splits messages into frames of at most `bytes` (at least 1), each taking
    /// `overhead` of airtime besides its bits.
    pub fn frames(mut self, bytes: usize, overhead: Duration) -> Self {
        self.frame_bytes = Some(bytes.max(1));
        self.frame_overhead = overhead;
        self
    }

    /// Bounds how long a message may wait for its transmitter.
    pub fn max_queue(mut self, wait: Duration) -> Self {
        self.max_queue = Some(wait);
        self
    }

    /// How many frames a message of `bytes` takes (at least one: an empty message is
    /// still a frame on the air).
    pub fn frame_count(&self, bytes: usize) -> u64 {
        let frames = self.frame_bytes.map_or(1, |f| bytes.div_ceil(f.max(1)));
        u64::try_from(frames.max(1)).unwrap_or(u64::MAX)
    }

    /// The largest frame a message of `bytes` puts on the air.
    pub fn largest_frame(&self, bytes: usize) -> usize {
        self.frame_bytes.map_or(bytes, |f| bytes.min(f))
    }

    /// How long a message of `bytes` occupies a transmitter of this link: its bits at
    /// the bandwidth, plus every frame's overhead.
    pub fn airtime(&self, bytes: usize) -> Duration {
        let frames = u32::try_from(self.frame_count(bytes)).unwrap_or(u32::MAX);
        self.transmit_time(bytes) + self.frame_overhead * frames
    }

    /// How long `bytes` occupy a transmitter of this link, frames' overhead aside.
    pub fn transmit_time(&self, bytes: usize) -> Duration {
        match self.bandwidth {
            None => Duration::ZERO,
            Some(bps) => {
                let nanos = (bytes as u128 * 8 * 1_000_000_000).div_ceil(u128::from(bps));
                Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
            }
        }
    }
}

/// Settings of a [`SimNet`](crate::SimNet).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// Links between modules of one robot (default: 100 µs, clean).
    pub robot: LinkConfig,
    /// Links between robots (default: 20 ms, clean).
    pub team: LinkConfig,
    /// How long after a peer becomes reachable the others hear it come up.
    pub liveliness_delay: Duration,
    /// How long after a peer becomes unreachable (killed, partitioned) the others hear
    /// it go down: the liveliness lease.
    pub lease: Duration,
    /// The largest step of virtual time: the clock never jumps further at once, so
    /// timers on it (heartbeats, trailing edges) run on time.
    pub step: Duration,
    /// Retransmission timeout of reliable sends.
    pub rto: Duration,
    /// Attempts of a reliable send before it is given up (counted as lost).
    pub max_attempts: u32,
    /// Do endpoints hear peers on other robots come up and go down? `false`: no peer
    /// events and no [`peers`](crate::Transport::peers) across robots (an acoustic
    /// modem has no lease, so robot death is judged from silence); the robot link's
    /// liveliness is unchanged, and publications and sends still cross. Set it before
    /// endpoints join: peers already up when it is switched off stay up in the views.
    pub team_liveliness: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            robot: LinkConfig::clean().delay(Duration::from_micros(100)),
            team: LinkConfig::clean().delay(Duration::from_millis(20)),
            liveliness_delay: Duration::from_millis(50),
            lease: Duration::from_secs(2),
            step: Duration::from_millis(10),
            rto: Duration::from_millis(200),
            max_attempts: 16,
            team_liveliness: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_occupies_the_link_for_its_bits() {
        let link = LinkConfig::clean().bandwidth(9600);
        assert_eq!(link.transmit_time(1200), Duration::from_secs(1));
        assert_eq!(LinkConfig::clean().transmit_time(1200), Duration::ZERO);
    }

    #[test]
    fn a_framed_message_pays_every_frames_overhead() {
        let link = LinkConfig::clean()
            .bandwidth(800)
            .frames(32, Duration::from_millis(100));
        assert_eq!(link.frame_count(100), 4);
        assert_eq!(link.frame_count(0), 1);
        assert_eq!(link.largest_frame(100), 32);
        assert_eq!(link.airtime(100), Duration::from_millis(1400));
        let plain = LinkConfig::clean().bandwidth(800);
        assert_eq!((plain.frame_count(100), plain.largest_frame(100)), (1, 100));
        assert_eq!(plain.airtime(100), plain.transmit_time(100));
    }
}
