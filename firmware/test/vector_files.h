// Reading the shared vector files (tests/vectors/, written by the Python side) in the host tests.
#pragma once

#include <doctest/doctest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

inline std::vector<uint8_t> read_vector_file(const std::string& name) {
  std::ifstream file(std::string(VECTORS_DIR) + "/" + name, std::ios::binary);
  REQUIRE_MESSAGE(file.good(), "cannot open vector file " << name);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(file), {});
}

inline float f32_at(const std::vector<uint8_t>& bytes, size_t offset) {
  float value;
  std::memcpy(&value, bytes.data() + offset, sizeof value);
  return value;
}
