"""Group a `perf record` profile of the `ins-gnss` program by what the time is spent on.

    cargo build --profile profiling -p ins-gnss
    perf record -F 4999 -g -o fwd.data target/profiling/ins-gnss run CONFIG --quiet \
        --accept-inconsistent --out /tmp/o
    python3 benches/perf_groups.py fwd.data

Each symbol of `perf report --no-children --sort sym` goes to the first group whose
pattern it matches (order matters: a smoother kernel is smoothing, not filter).
"""
import sys, re, subprocess
cats = [
 ("reading and parsing", r"ZSTD|lzma|inflate|dec2flt|FromStr|NumericLines|from_utf8|memchr|Reader|next_sample|parse|read_line|BufRead|fill_buf"),
 ("smoothing replay and backward pass", r"segments::|Smoother|variances_out_of|mat_mul|dense_sandwich|solve_lower|solve_upper|::transition|Store<|replay|Cholesky|cholesky"),
 ("formatting and writing", r"fixed::|itoa|grisu|dragon|float_to_decimal|pad_formatted|write_sigma|write_row|\bround\b|fmt::write|Formatter|copy_folio_from_iter|_copy_from_iter|generic_perform_write|ext4|write"),
 ("filter and mechanisation", r"sandwich_padded|wgs84|mechanization|step_covariance|error_blocks|HalfNoise|non_finite|So3|ErrorStateFilter|kernels::|GeoPos|InsState|InsModel|atan2|sincos|sin|cos|sqrt|align::|navigator|Navigator|p_times_ht|joseph|right_solve|block_reset|gate|adaptive"),
 ("threads and hand-offs", r"finish_task_switch|spin_unlock|lock_contended|futex|syscall|thread::|schedule|mpsc|Condvar|park|wake|__rseq|do_syscall|entry_SYSCALL"),
 ("memory copies and page faults", r"memmove|memset|memcpy|page_fault|clear_page|unmap_page|memcg|folio|alloc|malloc|free|mmap|zap|lru"),
]
def group(path):
    out = subprocess.run(["perf","report","-i",path,"--stdio","--no-children","--sort","sym"],capture_output=True,text=True).stdout
    tot = {c:0.0 for c,_ in cats}; tot["other"]=0.0
    for line in out.splitlines():
        m = re.match(r"\s+([\d.]+)%\s+\[[.k]\]\s+(.*)", line)
        if not m: continue
        p, sym = float(m.group(1)), m.group(2)
        for c, rx in cats:
            if re.search(rx, sym):
                tot[c]+=p; break
        else:
            tot["other"]+=p
    return tot
for path in sys.argv[1:]:
    t = group(path)
    print(path, " | ".join(f"{k} {v:.1f} %" for k,v in t.items()))
