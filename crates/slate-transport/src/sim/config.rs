//! The simulator's settings: faults and capacity per kind of link, and timing.

use std::time::Duration;

/// How one kind of link behaves. Probabilities are in `[0, 1]`.
///
/// ```
/// use slate_transport::LinkConfig;
/// use std::time::Duration;
/// // An acoustic-modem-like team link.
/// let team = LinkConfig::clean()
///     .delay(Duration::from_millis(50))
///     .bandwidth(9600)
///     .loss(0.1);
/// assert_eq!(team.bandwidth, Some(9600));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkConfig {
    /// Propagation delay added to every message.
    pub delay: Duration,
    /// Extra random delay, uniform in `[0, jitter]`, drawn per delivery: it reorders.
    pub jitter: Duration,
    /// Probability that a best-effort delivery (or one attempt of a reliable send) is lost.
    pub loss: f64,
    /// Probability that a best-effort delivery arrives twice.
    pub duplicate: f64,
    /// Capacity of each sender's transmitter on this kind of link, in bit/s (`None`:
    /// unlimited). A message occupies the transmitter for `bytes * 8 / bandwidth`;
    /// messages queue behind it.
    pub bandwidth: Option<u64>,
}

impl LinkConfig {
    /// No delay, no faults, no cap.
    pub fn clean() -> Self {
        LinkConfig {
            delay: Duration::ZERO,
            jitter: Duration::ZERO,
            loss: 0.0,
            duplicate: 0.0,
            bandwidth: None,
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

    /// How long `bytes` occupy a transmitter of this link.
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
}
