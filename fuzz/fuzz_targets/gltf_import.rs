#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shadetrace_fuzz::gltf_import(data));
