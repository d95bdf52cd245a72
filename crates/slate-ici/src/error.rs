//! [`Error`]: every error a program meets when it wires boards, plan engines and ICIs
//! together, folded into one, so a function doing all of it can return one type.

use slate_model::{
    AddressError, BatchError, ChainError, ClockDriftError, ClockError, CreateError, DefineError,
    DeleteError, FnError, LookupError, ReadError, ValueError, WriteError,
};
use slate_plans::LoadError;
use slate_wire::{DecodeError, EncodeError};

use crate::{IciStartError, PatternError, SendError, SendPlanError, SendRawError};

/// Any error of this crate, of the world model beneath it, of a `.slate` load or of the
/// codec. Each variant holds the precise error unchanged and displays as it does.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A board operation failed (every board error, through [`slate_model::Error`]).
    #[error(transparent)]
    Model(#[from] slate_model::Error),
    /// A `.slate` source did not load.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// A message could not be encoded.
    #[error(transparent)]
    Encode(#[from] EncodeError),
    /// Bytes received could not be decoded.
    #[error(transparent)]
    Decode(#[from] DecodeError),
    /// The ICI did not start ([`Ici::new`](crate::Ici::new)).
    #[error(transparent)]
    Start(#[from] IciStartError),
    /// A raw message could not be sent ([`Ici::send_raw`](crate::Ici::send_raw)).
    #[error(transparent)]
    SendRaw(#[from] SendRawError),
    /// A plan could not be sent ([`PlanCircuits::send`](crate::PlanCircuits::send)).
    #[error(transparent)]
    SendPlan(#[from] SendPlanError),
    /// A text is no address pattern ([`AddressPattern::new`](crate::AddressPattern::new)).
    #[error(transparent)]
    Pattern(#[from] PatternError),
    /// The transport refused a message.
    #[error(transparent)]
    Send(#[from] SendError),
}

/// `From` for each board error, through [`slate_model::Error`], so `?` folds it directly.
macro_rules! fold_model_errors {
    ($($error:ty),* $(,)?) => {
        $(
            impl From<$error> for Error {
                fn from(error: $error) -> Self {
                    Error::Model(error.into())
                }
            }
        )*
    };
}

fold_model_errors!(
    AddressError,
    BatchError,
    ChainError,
    ClockDriftError,
    ClockError,
    CreateError,
    DefineError,
    DeleteError,
    FnError,
    LookupError,
    ReadError,
    ValueError,
    WriteError,
);

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::Address;

    #[test]
    fn a_board_error_folds_through_the_model_error_and_displays_unchanged() {
        let parse = || -> Result<Address, Error> { Ok(Address::new("not an address")?) };
        let folded = parse().unwrap_err();
        let Error::Model(slate_model::Error::Address(inner)) = &folded else {
            panic!("an address error folds into Model(Address): {folded:?}");
        };
        assert_eq!(folded.to_string(), inner.to_string());
    }

    #[test]
    fn a_load_error_folds_into_error() {
        let board = std::sync::Arc::new(slate_model::Board::builder().build());
        let engine = slate_plans::Engine::new(&board);
        let load = || -> Result<(), Error> {
            engine.load("bad.slate", "class {")?;
            Ok(())
        };
        assert!(matches!(load(), Err(Error::Load(_))));
    }
}
