//! [`Error`]: every error of the world model folded into one, for code that calls
//! several board operations and propagates whatever fails with `?`.

use crate::{
    AddressError, BatchError, ChainError, ClockDriftError, ClockError, CreateError, DefineError,
    DeleteError, FnError, LookupError, ReadError, ValueError, WriteError,
};

/// Any error of this crate. Each variant holds the operation's own error unchanged and
/// displays as it does, so matching on the precise error stays possible and the text a
/// user sees is the same whichever type carries it.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Error {
    /// A class could not be defined ([`Board::define`](crate::Board::define)).
    #[error(transparent)]
    Define(#[from] DefineError),
    /// An object could not be created.
    #[error(transparent)]
    Create(#[from] CreateError),
    /// An object could not be deleted.
    #[error(transparent)]
    Delete(#[from] DeleteError),
    /// An attribute could not be read.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// An attribute could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// A batch of writes was refused as a whole.
    #[error(transparent)]
    Batch(#[from] BatchError),
    /// An object or attribute name did not resolve.
    #[error(transparent)]
    Lookup(#[from] LookupError),
    /// A chain of active functions was cut (depth or cycle).
    #[error(transparent)]
    Chain(#[from] ChainError),
    /// A text is not a valid module address.
    #[error(transparent)]
    Address(#[from] AddressError),
    /// A value or its quality (accuracy, confidence) is not acceptable.
    #[error(transparent)]
    Value(#[from] ValueError),
    /// A manual clock could not be moved.
    #[error(transparent)]
    Clock(#[from] ClockError),
    /// A received timestamp was too far ahead of local time.
    #[error(transparent)]
    ClockDrift(#[from] ClockDriftError),
    /// An active function failed.
    #[error(transparent)]
    Fn(#[from] FnError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Address, Board, ClassDef, Clock};

    /// Defines and creates through `?` into the one error type; the second create names
    /// a class that does not exist.
    fn create_of_unknown_class(board: &Board) -> Result<(), Error> {
        board.define(ClassDef::new("Rock"))?;
        board.create("Rock", "r1")?;
        board.create("Boulder", "r2")?;
        Ok(())
    }

    #[test]
    fn board_errors_fold_into_error_and_display_unchanged() {
        let board = Board::builder().clock(Clock::manual()).build();
        let folded = create_of_unknown_class(&board).unwrap_err();
        let Error::Create(inner) = &folded else {
            panic!("a create error stays a create error: {folded:?}");
        };
        assert_eq!(folded.to_string(), inner.to_string());
    }

    #[test]
    fn an_address_error_folds_into_error() {
        let parse = || -> Result<Address, Error> { Ok(Address::new("not an address")?) };
        assert!(matches!(parse(), Err(Error::Address(_))));
    }
}
