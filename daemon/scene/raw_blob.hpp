// The bytes an isolated importer child hands back to the parent: a small
// header, then the raw positions and triangles. The parent treats them as
// untrusted (a half-dead child may write anything), so decode checks sizes.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "scene/assimp_reader.hpp"

namespace sculpt::scene {

std::vector<std::byte> encode_raw(const RawImport& raw);
// Throws std::runtime_error if the bytes are not a well-formed blob.
RawImport decode_raw(std::span<const std::byte> bytes);

}  // namespace sculpt::scene
