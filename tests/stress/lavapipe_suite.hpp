// SPDX-License-Identifier: Apache-2.0
// A test suite whose probes run on Mesa lavapipe: the device is opened once per suite (a failure to open it fails
// every test, never skips one), and the suite's JSON report (bench/REPORT.md reads it) is written when it ends,
// to $<Suite::kReportEnvironment> or to Suite::kReportPath. CRTP: each suite has its own device and report.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "probe/lavapipe.hpp"

namespace kiln::gpu {

template <typename Suite>
class LavapipeSuite : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto opened = Lavapipe::open();
    if (opened) gpu_ = std::move(*opened).release();
    else open_error_ = opened.error().message;
  }
  static void TearDownTestSuite() {
    delete gpu_;
    gpu_ = nullptr;
    report_["device"] = device_;
    const char* path = std::getenv(Suite::kReportEnvironment);
    std::ofstream(path ? path : Suite::kReportPath) << report_.dump(2) << "\n";
  }
  void SetUp() override {
    ASSERT_NE(gpu_, nullptr) << open_error_;
    ASSERT_TRUE(gpu_->supports_float16()) << "lavapipe without shaderFloat16 cannot run the fp16 variants";
    device_ = gpu_->device_name() + " (" + gpu_->driver_info() + ")";
  }

  static inline Lavapipe* gpu_ = nullptr;
  static inline std::string open_error_;
  static inline std::string device_;
  static inline nlohmann::json report_;
};

}  // namespace kiln::gpu
