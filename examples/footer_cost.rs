//! Cost of opening one shard's footer: a full parse against one that reuses the first shard's
//! schema and skips statistics (what `Bank::open` does for every shard after the first).
//! `cargo run --release --example footer_cost -- SHARD_0.parquet SHARD_1.parquet`
use parquet::arrow::arrow_reader::{ArrowReaderMetadata, ArrowReaderOptions};
use parquet::file::metadata::{
    ParquetMetaDataOptions, ParquetMetaDataReader, ParquetStatisticsPolicy,
};
use std::time::Instant;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let map = |p: &str| {
        let f = std::fs::File::open(p).unwrap();
        bytes::Bytes::from_owner(unsafe { memmap2::Mmap::map(&f).unwrap() })
    };
    let b0 = map(&a[1]);
    let b1 = map(&a[2]);
    let md0 = ParquetMetaDataReader::new().parse_and_finish(&b0).unwrap();
    let schema = md0.file_metadata().schema_descr_ptr();
    let am0 = ArrowReaderMetadata::try_new(
        std::sync::Arc::new(md0),
        ArrowReaderOptions::new().with_skip_arrow_metadata(true),
    )
    .unwrap();
    for _ in 0..3 {
        let t = Instant::now();
        let opts = ParquetMetaDataOptions::new()
            .with_schema(schema.clone())
            .with_encoding_stats_policy(ParquetStatisticsPolicy::SkipAll)
            .with_column_stats_policy(ParquetStatisticsPolicy::SkipAll)
            .with_size_stats_policy(ParquetStatisticsPolicy::SkipAll);
        let md = ParquetMetaDataReader::new()
            .with_metadata_options(Some(opts))
            .parse_and_finish(&b1)
            .unwrap();
        let x = t.elapsed();
        let t = Instant::now();
        let _m = ArrowReaderMetadata::try_new(
            std::sync::Arc::new(md),
            ArrowReaderOptions::new()
                .with_skip_arrow_metadata(true)
                .with_schema(am0.schema().clone()),
        )
        .unwrap();
        let y = t.elapsed();
        println!(
            "shared-schema parse {:.2} ms, arrow try_new {:.2} ms",
            x.as_secs_f64() * 1e3,
            y.as_secs_f64() * 1e3
        );
    }
}
