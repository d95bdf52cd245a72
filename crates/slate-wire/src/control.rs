//! Bodies of the small messages: plans, acks, cancels, catch-up requests, heartbeats.

use crate::bits::{BitReader, BitWriter};
use crate::error::check_len;
use crate::text::{read_address, write_address};
use crate::{
    CatchUpRequest, DecodeError, EncodeError, Heartbeat, MAX_NAME_BYTES, MAX_TEXT_BYTES, Plan,
    PlanAck, PlanStep,
};

/// Writes a plan: circuit, name, source text, destination, origin.
pub(crate) fn write_plan(w: &mut BitWriter, p: &Plan) -> Result<(), EncodeError> {
    check_len("plan name length", p.name.len(), MAX_NAME_BYTES)?;
    check_len("plan text length", p.source_text.len(), MAX_TEXT_BYTES)?;
    w.uvar(p.circuit);
    w.str(&p.name);
    w.str(&p.source_text);
    write_address(w, &p.to);
    write_address(w, &p.origin);
    Ok(())
}

pub(crate) fn read_plan(r: &mut BitReader) -> Result<Plan, DecodeError> {
    Ok(Plan {
        circuit: r.uvar()?,
        name: r.str("plan name length", MAX_NAME_BYTES)?,
        source_text: r.str("plan text length", MAX_TEXT_BYTES)?,
        to: read_address(r)?,
        origin: read_address(r)?,
    })
}

/// Bits of a step tag.
const STEP_BITS: u32 = 4;

/// Writes an ack: circuit, step sequence number, a 4-bit step tag and its fields.
pub(crate) fn write_ack(w: &mut BitWriter, a: &PlanAck) -> Result<(), EncodeError> {
    w.uvar(a.circuit);
    w.uvar(a.seq);
    let (tag, text) = match &a.step {
        PlanStep::Received => (0, None),
        PlanStep::Accepted => (1, None),
        PlanStep::Rejected { reason } => (2, Some(reason)),
        PlanStep::Initiated => (3, None),
        PlanStep::Triggered { ok, detail } => (4 + u64::from(*ok), Some(detail)),
        PlanStep::Terminated => (6, None),
        PlanStep::Cancelled => (7, None),
        PlanStep::DestinationLost => (8, None),
    };
    w.bits(tag, STEP_BITS);
    if let Some(text) = text {
        check_len("ack text length", text.len(), MAX_TEXT_BYTES)?;
        w.str(text);
    }
    Ok(())
}

pub(crate) fn read_ack(r: &mut BitReader) -> Result<PlanAck, DecodeError> {
    let circuit = r.uvar()?;
    let seq = r.uvar()?;
    let text = |r: &mut BitReader| r.str("ack text length", MAX_TEXT_BYTES);
    let step = match r.bits(STEP_BITS)? {
        0 => PlanStep::Received,
        1 => PlanStep::Accepted,
        2 => PlanStep::Rejected { reason: text(r)? },
        3 => PlanStep::Initiated,
        tag @ (4 | 5) => PlanStep::Triggered {
            ok: tag == 5,
            detail: text(r)?,
        },
        6 => PlanStep::Terminated,
        7 => PlanStep::Cancelled,
        8 => PlanStep::DestinationLost,
        _ => return Err(DecodeError::BadValue("reserved plan step")),
    };
    Ok(PlanAck { circuit, seq, step })
}

/// Writes a catch-up request: the sequence number held, then the two need bits.
pub(crate) fn write_catch_up(w: &mut BitWriter, c: &CatchUpRequest) {
    w.uvar(c.have_seq);
    w.bit(c.needs_names);
    w.bit(c.needs_classes);
}

pub(crate) fn read_catch_up(r: &mut BitReader) -> Result<CatchUpRequest, DecodeError> {
    Ok(CatchUpRequest {
        have_seq: r.uvar()?,
        needs_names: r.bit()?,
        needs_classes: r.bit()?,
    })
}

/// Writes a heartbeat: four varints.
pub(crate) fn write_heartbeat(w: &mut BitWriter, h: &Heartbeat) {
    [h.seq, h.sent, h.received, h.rejected]
        .into_iter()
        .for_each(|v| w.uvar(v));
}

pub(crate) fn read_heartbeat(r: &mut BitReader) -> Result<Heartbeat, DecodeError> {
    Ok(Heartbeat {
        seq: r.uvar()?,
        sent: r.uvar()?,
        received: r.uvar()?,
        rejected: r.uvar()?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_plan_step_roundtrips() {
        let steps = crate::step::tests::every_step();
        for (seq, step) in steps.into_iter().enumerate() {
            let ack = PlanAck {
                circuit: 9,
                seq: seq as u64,
                step,
            };
            let mut w = BitWriter::new();
            write_ack(&mut w, &ack).unwrap();
            let bytes = w.finish();
            assert_eq!(read_ack(&mut BitReader::new(&bytes)), Ok(ack));
        }
    }

    #[test]
    fn reserved_steps_are_bad_values() {
        let mut w = BitWriter::new();
        w.uvar(1);
        w.uvar(1);
        w.bits(9, STEP_BITS);
        let bytes = w.finish();
        assert!(matches!(
            read_ack(&mut BitReader::new(&bytes)),
            Err(DecodeError::BadValue(_))
        ));
    }
}
