// mimalloc instead of the system allocator: a cold `identify` touches some 20 MB of fresh
// heap (parameters, cells, graph, greedy partitions); glibc gives it back page by page and
// every first touch is a page fault (about 5,000 a process); mimalloc's segments cut that to
// about 1,400 (docs/cold-start.md).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
