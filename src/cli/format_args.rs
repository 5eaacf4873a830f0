//! The storage-format arguments of `bank generate`: the command line's names for the library's
//! [`Codec`] and [`ValueEncoding`] (the library itself knows nothing of clap).

use clap::ValueEnum;
use wheelflat::bank::{Codec, ValueEncoding};

/// `--compression`: the compression of the force columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum CodecArg {
    /// No compression: reading is a copy.
    None,
    /// Snappy.
    Snappy,
    /// LZ4 (raw).
    Lz4,
    /// Zstandard, level 1.
    Zstd,
}

impl From<CodecArg> for Codec {
    fn from(c: CodecArg) -> Codec {
        match c {
            CodecArg::None => Codec::None,
            CodecArg::Snappy => Codec::Snappy,
            CodecArg::Lz4 => Codec::Lz4,
            CodecArg::Zstd => Codec::Zstd,
        }
    }
}

/// `--encoding`: the value encoding of the force columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum EncodingArg {
    /// Plain little-endian floats.
    Plain,
    /// Byte-stream split: the bytes of all floats grouped by significance.
    ByteStreamSplit,
}

impl From<EncodingArg> for ValueEncoding {
    fn from(e: EncodingArg) -> ValueEncoding {
        match e {
            EncodingArg::Plain => ValueEncoding::Plain,
            EncodingArg::ByteStreamSplit => ValueEncoding::ByteStreamSplit,
        }
    }
}
