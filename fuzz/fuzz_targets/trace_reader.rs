#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shadetrace_fuzz::trace_reader(data));
