// SPDX-License-Identifier: Apache-2.0
#include "scene/image.hpp"
#include "scene/verify_error.hpp"

#include <png.h>
#include <unistd.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include "kiln/output_file.hpp"
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace kiln::render {
namespace {

double aces_fitted(double x) {
  // Narkowicz 2015, "ACES Filmic Tone Mapping Curve" (the display curve, not the shader under test).
  return std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

double srgb_encode(double linear) {
  linear = std::clamp(linear, 0.0, 1.0);
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

std::optional<std::string> read_binary(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  if (!(in && bytes << in.rdbuf())) return std::nullopt;
  return std::move(bytes).str();
}

}  // namespace

void create_output_directory(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) fail(DiagId::OutputUnwritable, dir, "cannot make the directory: " + ec.message());
}

void write_output(const std::filesystem::path& path, std::string_view bytes) {
  if (Result<void> written = write_output_file(path, bytes); !written) fail(DiagId::OutputUnwritable, path, written.error().message);
}

std::vector<uint8_t> encode_srgb8(const Image& image, bool apply_aces) {
  std::vector<uint8_t> out(size_t(image.width) * image.height * 4);
  for (size_t i = 0; i < out.size(); ++i) {
    if (i % 4 == 3) {
      out[i] = 255;
      continue;
    }
    double v = image.rgba[i];
    if (!std::isfinite(v)) v = 0;  // NaN/Inf are reported by the metrics, not by the encoder
    if (apply_aces) v = aces_fitted(v);
    out[i] = static_cast<uint8_t>(std::lround(srgb_encode(v) * 255.0));
  }
  return out;
}

void write_png(const std::filesystem::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba8) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = width;
  png.height = height;
  png.format = PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;
  if (!png_image_write_get_memory_size(png, size, 0, rgba8.data(), 0, nullptr))
    fail(DiagId::OutputUnwritable, path, std::string("PNG encoding failed: ") + png.message);
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, rgba8.data(), 0, nullptr))
    fail(DiagId::OutputUnwritable, path, std::string("PNG encoding failed: ") + png.message);
  bytes.resize(size);
  write_output(path, bytes);
}

std::vector<uint8_t> read_png(const std::filesystem::path& path, uint32_t& width, uint32_t& height) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str()))
    fail(DiagId::GoldenData, path, std::string("cannot read the PNG image: ") + png.message);
  png.format = PNG_FORMAT_RGBA;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr))
    fail(DiagId::GoldenData, path, std::string("cannot decode the PNG image: ") + png.message);
  width = png.width;
  height = png.height;
  return pixels;
}

void write_exr(const std::filesystem::path& path, const Image& image) {
  // In the temporary directory, not beside the path: the path may be a device (`-o /dev/null`).
  std::error_code no_tmp;
  std::filesystem::path temporary = std::filesystem::temp_directory_path(no_tmp);
  if (no_tmp) temporary = "/tmp";
  static std::atomic<unsigned> counter{0};
  temporary /= "kiln-exr-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".exr";
  {
    Imf::Header header(static_cast<int>(image.width), static_cast<int>(image.height));
    const char* names[4] = {"R", "G", "B", "A"};
    Imf::FrameBuffer frame;
    for (int c = 0; c < 4; ++c) {
      header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
      frame.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(image.rgba.data() + c)),
                                        sizeof(float) * 4, sizeof(float) * 4 * image.width));
    }
    try {
      Imf::OutputFile file(temporary.c_str(), header);
      file.setFrameBuffer(frame);
      file.writePixels(static_cast<int>(image.height));
    } catch (const std::exception& e) {  // OpenEXR reports a file it cannot create or write with an exception
      std::error_code ec;
      std::filesystem::remove(temporary, ec);
      fail(DiagId::OutputUnwritable, path, std::string("cannot write the OpenEXR image: ") + e.what());
    }
  }
  // OpenEXR writes (and seeks in) a file of its own; its bytes then go where they were asked for, as every output's.
  std::optional<std::string> bytes = read_binary(temporary);
  std::error_code ignored;
  std::filesystem::remove(temporary, ignored);
  if (!bytes) fail(DiagId::OutputUnwritable, path, "cannot read back the OpenEXR image written beside it");
  write_output(path, *bytes);
}

void write_kimg(const std::filesystem::path& path, const Image& image) {
  std::string bytes = "KIMG";
  auto put = [&](uint32_t v) { bytes.append(reinterpret_cast<const char*>(&v), 4); };
  put(1);
  put(image.width);
  put(image.height);
  bytes.append(reinterpret_cast<const char*>(image.rgba.data()), image.rgba.size() * sizeof(float));
  write_output(path, bytes);
}

Image read_kimg(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  std::string bytes = text.str();
  auto bad = [&](const std::string& m) { fail(DiagId::GoldenData, path, m); };
  if (!in) bad("cannot open the image");
  if (bytes.size() < 16 || bytes.compare(0, 4, "KIMG") != 0) bad("not a KIMG image");
  uint32_t header[3];
  std::memcpy(header, bytes.data() + 4, 12);
  if (header[0] != 1) bad("KIMG version " + std::to_string(header[0]) + " (expected 1)");
  Image image;
  image.width = header[1];
  image.height = header[2];
  size_t floats = size_t(image.width) * image.height * 4;
  if (bytes.size() != 16 + floats * 4) bad("truncated KIMG image");
  image.rgba.resize(floats);
  std::memcpy(image.rgba.data(), bytes.data() + 16, floats * 4);
  return image;
}

}  // namespace kiln::render
