//! Value parsers of the arguments that take a bounded number (threads, speeds, shards): each
//! refuses with the value and the range, clap naming the argument.

/// The most worker threads a run may ask for.
const MAX_THREADS: usize = 1024;

// Err(String): a clap value parser: clap names the argument and prints the message.
pub(super) fn parse_threads(s: &str) -> std::result::Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_THREADS).contains(&n) => Ok(n),
        _ => Err(format!(
            "`{s}`: a whole number of threads from 1 to {MAX_THREADS}"
        )),
    }
}

// Err(String): a clap value parser: clap names the argument and prints the message.
pub(super) fn parse_speed(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (1.0..=500.0).contains(&v) => Ok(v),
        _ => Err(format!("`{s}`: a train speed in km/h from 1 to 500")),
    }
}

/// Parses `--shard I/N`.
// Err(String): a clap value parser: clap names the argument and prints the message.
pub(super) fn parse_shard(s: &str) -> std::result::Result<(usize, usize), String> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}`: expected I/N, e.g. 0/4"))?;
    let i: usize = i
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: I is not a number"))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: N is not a number"))?;
    if n == 0 || i >= n {
        return Err(format!("`{s}`: need 0 <= I < N"));
    }
    Ok((i, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_reject() {
        assert_eq!(parse_shard("3/10"), Ok((3, 10)));
        assert_eq!(parse_shard(" 0 / 1 "), Ok((0, 1)));
        assert!(parse_shard("10/10").is_err());
        assert!(parse_shard("1/0").is_err());
        assert!(parse_shard("3").is_err());
    }
}
