#!/usr/bin/env python3
"""A KHR_texture_basisu variant of a GLB: every image re-encoded to KTX2 by Basis
Universal (PyPI's alktx2, which wraps the reference basisu encoder and transcoder).

usage: ktx2-variant.py IN.glb OUT.glb etc1s|uastc [REFERENCE.png]

uastc is Zstandard-supercompressed. With REFERENCE.png, the first image's KTX2 is also
decoded by Basis Universal's own transcoder and written there, for tests to compare with.
"""
import json
import struct
import sys

import alktx2


def read_glb(path):
    data = open(path, "rb").read()
    assert data[:4] == b"glTF", f"{path}: not a GLB"
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + json_len])
    at = 20 + json_len
    bin_len = struct.unpack_from("<I", data, at)[0]
    return doc, bytearray(data[at + 8 : at + 8 + bin_len])


def write_glb(path, doc, bin_chunk):
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    bin_chunk += b"\0" * (-len(bin_chunk) % 4)
    total = 12 + 8 + len(text) + 8 + len(bin_chunk)
    with open(path, "wb") as out:
        out.write(b"glTF" + struct.pack("<II", 2, total))
        out.write(struct.pack("<I", len(text)) + b"JSON" + text)
        out.write(struct.pack("<I", len(bin_chunk)) + b"BIN\0" + bytes(bin_chunk))


def image_bytes(doc, bin_chunk, image):
    view = doc["bufferViews"][image["bufferView"]]
    start = view.get("byteOffset", 0)
    return bytes(bin_chunk[start : start + view["byteLength"]])


def main():
    src, dst, codec = sys.argv[1:4]
    reference = sys.argv[4] if len(sys.argv) > 4 else None
    doc, bin_chunk = read_glb(src)
    for i, image in enumerate(doc.get("images", [])):
        mime = image.get("mimeType", "image/png")
        encoded = alktx2.encode_bytes_to_ktx2(
            image_bytes(doc, bin_chunk, image),
            mime=mime,
            codec=codec,
            zstd_supercompression_level=(9 if codec == "uastc" else None),
        )
        if reference and i == 0:
            png, _ = alktx2.decode_ktx2_to_bytes(encoded, format="png")
            open(reference, "wb").write(png)
        bin_chunk += b"\0" * (-len(bin_chunk) % 4)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(bin_chunk), "byteLength": len(encoded)})
        bin_chunk += encoded
        doc["images"][i] = {"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/ktx2"}
    for texture in doc.get("textures", []):
        extensions = texture.setdefault("extensions", {})
        # A WebP-only texture names its image in EXT_texture_webp.
        webp = extensions.pop("EXT_texture_webp", None)
        source = texture.pop("source", None)
        extensions["KHR_texture_basisu"] = {"source": webp["source"] if webp else source}
    for key in ("extensionsUsed", "extensionsRequired"):
        used = set(doc.get(key, [])) - {"EXT_texture_webp"}
        doc[key] = sorted(used | {"KHR_texture_basisu"})
    doc["buffers"][0]["byteLength"] = len(bin_chunk)
    write_glb(dst, doc, bin_chunk)


main()
