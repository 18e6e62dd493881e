// SPDX-License-Identifier: Apache-2.0
#include "common/compile_result.hpp"

#include <stdexcept>

#include "kiln/bounded_json.hpp"

namespace kiln {
namespace {

using nlohmann::json;

std::vector<uint32_t> binary_to_words(const std::vector<uint8_t>& bytes) {
  return spirv_from_bytes(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace

std::vector<uint8_t> encode_output(const JobOutput& output, bool with_steps) {
  json j{{"ok", output.ok}, {"failed_step", std::string(step_name(output.failed_step))}};
  json messages = json::array();
  for (const FrontendMessage& m : output.messages) {
    json message{{"severity", static_cast<int>(m.severity)}, {"path", m.path}, {"line", m.line}, {"text", m.text},
                 {"column", m.column}};
    if (!m.token.empty()) message["token"] = {m.token, m.occurrence};
    messages.push_back(std::move(message));
  }
  j["messages"] = messages;
  j["spirv"] = json::binary(spirv_to_bytes(output.spirv));
  json blobs = json::object();
  for (const auto& [target, blob] : output.blobs)
    blobs[std::string(target_name(target))] = {json::binary(std::vector<uint8_t>(blob.stored.begin(), blob.stored.end())),
                                               blob.raw_size, blob.checksum, blob.key.low, blob.key.high};
  j["blobs"] = blobs;
  // Front-end and preprocessing outputs have none (null, as before the reflection was typed).
  j["reflection"] = output.reflection == Reflection{} ? json() : json(output.reflection);
  j["full_legalization"] = output.full_legalization;
  if (!output.preprocessed.empty() || !output.files_read.empty()) {
    j["preprocessed"] = output.preprocessed;
    j["files_read"] = output.files_read;
  }
  if (with_steps && !output.steps.empty()) {
    json steps = json::array();
    for (const StepSpan& span : output.steps) steps.push_back({step_name(span.step), span.start_us, span.duration_us});
    j["steps"] = std::move(steps);
    j["steps_elapsed_us"] = output.steps_elapsed_us;
  }
  return json::to_cbor(j);
}

JobOutput decode_output(const std::vector<uint8_t>& bytes) {
  return decode_output(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

JobOutput decode_output(std::string_view bytes) {
  json j = decode_cbor_bounded(bytes, {bytes.size(), kMaxJsonDepth});
  JobOutput out;
  out.ok = j.at("ok").get<bool>();
  const auto step = parse_step(j.at("failed_step").get<std::string>());
  if (!step) throw std::runtime_error("unknown compile step in a worker's output");
  out.failed_step = *step;
  for (const json& m : j.at("messages")) {
    out.messages.push_back({static_cast<Severity>(m.at("severity").get<int>()), m.at("path").get<std::string>(),
                            m.at("line").get<int>(), m.at("text").get<std::string>(), m.at("column").get<int>()});
    if (m.contains("token")) {
      out.messages.back().token = m.at("token").at(0).get<std::string>();
      out.messages.back().occurrence = m.at("token").at(1).get<int>();
    }
  }
  out.spirv = binary_to_words(j.at("spirv").get_binary());
  for (auto& [name, fields] : j.at("blobs").items()) {
    auto target = parse_target(name);
    if (!target || fields.size() != 5) throw std::runtime_error("malformed output blob");
    PackedBlob blob;
    const auto& stored = fields.at(0).get_binary();
    blob.stored.assign(stored.begin(), stored.end());
    blob.raw_size = fields.at(1).get<uint64_t>();
    blob.checksum = fields.at(2).get<uint64_t>();
    blob.key = {fields.at(3).get<uint64_t>(), fields.at(4).get<uint64_t>()};
    if (blob.stored.size() > blob.raw_size) throw std::runtime_error("malformed output blob");
    out.blobs[*target] = std::move(blob);
  }
  if (const json& reflection = j.at("reflection"); !reflection.is_null()) out.reflection = reflection.get<Reflection>();
  out.full_legalization = j.at("full_legalization").get<bool>();
  if (j.contains("preprocessed")) {
    out.preprocessed = j.at("preprocessed").get<std::string>();
    out.files_read = j.at("files_read").get<std::vector<std::string>>();
  }
  if (j.contains("steps")) {
    // A worker's answer is untrusted: a bounded count of known steps, each within a day, in order, none overlapping.
    constexpr uint64_t kMaxStepMicroseconds = uint64_t{86400} * 1000 * 1000;
    const json& steps = j.at("steps");
    if (!steps.is_array() || steps.size() > kMaxStepSpans) throw std::runtime_error("malformed step times");
    uint64_t previous_end = 0;
    for (const json& s : steps) {
      if (!s.is_array() || s.size() != 3 || !s.at(1).is_number_unsigned() || !s.at(2).is_number_unsigned())
        throw std::runtime_error("malformed step time");
      const auto kind = parse_step(s.at(0).get<std::string>());
      StepSpan span{kind.value_or(CompileStep::None), s.at(1).get<uint64_t>(), s.at(2).get<uint64_t>()};
      if (!kind || *kind == CompileStep::None || span.start_us > kMaxStepMicroseconds ||
          span.duration_us > kMaxStepMicroseconds || span.start_us < previous_end)
        throw std::runtime_error("malformed step time");
      previous_end = span.start_us + span.duration_us;
      out.steps.push_back(span);
    }
    const json& elapsed = j.at("steps_elapsed_us");
    if (!elapsed.is_number_unsigned() || elapsed.get<uint64_t>() > kMaxStepMicroseconds ||
        elapsed.get<uint64_t>() < previous_end)
      throw std::runtime_error("malformed step times");
    out.steps_elapsed_us = elapsed.get<uint64_t>();
  }
  return out;
}

}  // namespace kiln
