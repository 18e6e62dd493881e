// SPDX-License-Identifier: Apache-2.0
// Float RGBA images and their files: PNG (8-bit sRGB, libpng), OpenEXR (32-bit float), and KIMG (kiln's raw
// float image: "KIMG", u32 version 1, u32 width, u32 height, float32 RGBA rows, top row first). Every
// writer goes through a temporary file and a rename.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace kiln::render {

// Reference alpha marking a pixel whose shadow test is tied within fp32 error of its inputs (a shadow edge
// that may fall on either side of the pixel): excluded from both metrics and counted separately.
inline constexpr float kUnstablePixel = 2.0f;

struct Image {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> rgba;  // width * height * 4, top row first
  float* pixel(uint32_t x, uint32_t y) { return &rgba[(size_t(y) * width + x) * 4]; }
  const float* pixel(uint32_t x, uint32_t y) const { return &rgba[(size_t(y) * width + x) * 4]; }
};

// Display encoding: optional ACES (Narkowicz's fit, for linear-radiance images), clamp, sRGB transfer
// function, 8 bits, alpha 255.
std::vector<uint8_t> encode_srgb8(const Image& image, bool apply_aces);

void write_png(const std::filesystem::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba8);
std::vector<uint8_t> read_png(const std::filesystem::path& path, uint32_t& width, uint32_t& height);
void write_exr(const std::filesystem::path& path, const Image& image);
void write_kimg(const std::filesystem::path& path, const Image& image);
Image read_kimg(const std::filesystem::path& path);

// Creates `dir` and its parents; one that cannot be made is K1601 (OutputUnwritable, exit 3).
void create_output_directory(const std::filesystem::path& dir);
// Writes `bytes` to `path` as kiln writes every output (kiln/output_file.hpp: atomic for a regular file, in place
// for a device or a FIFO, never through a link); fails with K1601 when it cannot.
void write_output(const std::filesystem::path& path, std::string_view bytes);

}  // namespace kiln::render
