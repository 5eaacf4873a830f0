//! Cost of opening one shard's footer: a full load against the parse `Bank::open` does for
//! every shard after the first (the first shard's schema, no statistics:
//! `bank::schema::sibling_footer_options`) and the Arrow schema built on it.
//! `cargo bench --bench footer_cost -- SHARD_0.parquet SHARD_1.parquet`
use parquet::arrow::arrow_reader::{ArrowReaderMetadata, ArrowReaderOptions};
use parquet::file::metadata::ParquetMetaDataReader;
use std::time::Instant;
use wheelflat::bank::schema::sibling_footer_options;

fn main() {
    let a: Vec<String> = std::env::args().filter(|a| a != "--bench").collect();
    // A probe, not a criterion bench: without its shards (as in a plain `cargo bench`) it says so.
    if a.len() < 3 {
        eprintln!(
            "footer_cost: a timing probe; run `cargo bench --bench footer_cost -- SHARD_0 SHARD_1`"
        );
        return;
    }
    let map = |p: &str| {
        let f = std::fs::File::open(p).unwrap();
        // SAFETY: a bank's shard files are not modified once renamed into place.
        bytes::Bytes::from_owner(unsafe { memmap2::Mmap::map(&f).unwrap() })
    };
    let (b0, b1) = (map(&a[1]), map(&a[2]));
    let first = ArrowReaderMetadata::load(&b0, ArrowReaderOptions::new()).unwrap();
    let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
    for _ in 0..3 {
        let t = Instant::now();
        let _full = ArrowReaderMetadata::load(&b1, ArrowReaderOptions::new()).unwrap();
        let full = ms(t);
        let t = Instant::now();
        let md = ParquetMetaDataReader::new()
            .with_metadata_options(Some(sibling_footer_options(&first)))
            .parse_and_finish(&b1)
            .unwrap();
        let parse = ms(t);
        let t = Instant::now();
        let _m = ArrowReaderMetadata::try_new(
            std::sync::Arc::new(md),
            ArrowReaderOptions::new()
                .with_skip_arrow_metadata(true)
                .with_schema(first.schema().clone()),
        )
        .unwrap();
        println!(
            "full load {full:.2} ms; sibling parse {parse:.2} ms + Arrow schema {:.2} ms",
            ms(t)
        );
    }
}
