// SPDX-License-Identifier: Apache-2.0
#include "layouts/layout_check.hpp"

#include <algorithm>
#include <set>

#include "reflect/reflect.hpp"

namespace kiln {
namespace {

// The D3D register class a reflected resource comes from ('t' or 'u' for a storage buffer: read-only
// StructuredBuffer and ByteAddressBuffer are t, their RW forms u).
std::string register_classes(const Resource& resource) {
  switch (resource.kind) {
    case ResourceKind::UniformBuffer: return "b";
    case ResourceKind::Sampler: return "s";
    case ResourceKind::StorageImage:
    case ResourceKind::StorageTexelBuffer: return "u";
    case ResourceKind::StorageBuffer: return "tu";
    case ResourceKind::Texture:
    case ResourceKind::CombinedImageSampler:
    case ResourceKind::UniformTexelBuffer:
    case ResourceKind::InputAttachment: return "t";
  }
  return "t";
}

std::string describe(const Resource& resource) {
  if (resource.name == "$Global") return "the implicit $Global uniform block (global variables outside any cbuffer)";
  return "'" + resource.name + "' (" + std::string(resource_kind_name(resource.kind)) + ")";
}

std::string slot_text(const Resource& resource) {
  return "set " + std::to_string(resource.set) + " binding " + std::to_string(resource.binding);
}

// "texture (2D)", "texture (2D, array of 4)", "uniform_buffer"
std::string descriptor_text(const Resource& resource) {
  std::string detail = resource.dimension;
  if (resource.count != 1)
    detail += (detail.empty() ? "" : ", ") + (resource.count == 0 ? std::string("unbounded array") : "array of " + std::to_string(resource.count));
  return "a " + std::string(resource_kind_name(resource.kind)) + (detail.empty() ? "" : " (" + detail + ")");
}

std::string count_text(size_t n) { return std::to_string(n) + (n == 1 ? " variant" : " variants"); }

class Checker {
 public:
  Checker(const PassLayoutInput& input, DiagnosticSink& sink) : in_(input), sink_(sink) {}

  void report(const LayoutClash& clash) {
    if (clash.kind == LayoutClash::Kind::MemberMismatch) {
      report_members(clash);
      return;
    }
    const Resource& a = clash.first;
    const Resource& b = clash.second;
    const Together together = find_together(a, b);
    std::string message = "pass '" + in_.pass + "': ";
    std::vector<std::string> notes;
    if (clash.kind == LayoutClash::Kind::SharedSlot && a.name == b.name) {
      if (!together.stage_pairs.empty()) {
        const auto [sa, sb] = *together.stage_pairs.begin();
        message += "'" + a.name + "' is " + descriptor_text(a) + " in the " + std::string(stage_name(sa)) + " stage and " +
                   descriptor_text(b) + " in the " + std::string(stage_name(sb)) + " stage of the same variant (" +
                   slot_text(a) + "), in " + count_text(together.variants.size());
        notes.push_back("Vulkan needs one descriptor type, count and image dimension per binding in every stage of a "
                        "pipeline: declare the resource once, in a file both stages include");
      } else {
        message += "'" + a.name + "' is " + descriptor_text(a) + " in " + first_variants(holders(a)) + " and " +
                   descriptor_text(b) + " in " + first_variants(holders(b)) + " (" + slot_text(a) + ")";
        notes.push_back("a resource's descriptor type, count and dimension must not depend on keywords: give each form "
                        "its own name and binding");
      }
    } else if (clash.kind == LayoutClash::Kind::SharedSlot) {
      message += slot_text(a) + " holds both " + describe(a) + " and " + describe(b);
      if (together.same_binary) {
        message += " in the " + std::string(stage_name(stage_of(holders(a), holders(b)))) + " stage, in " +
                   count_text(together.variants.size());
      } else if (!together.stage_pairs.empty()) {
        const auto [sa, sb] = *together.stage_pairs.begin();
        message = "pass '" + in_.pass + "': " + slot_text(a) + " holds " + describe(a) + " in the " + std::string(stage_name(sa)) +
                  " stage and " + describe(b) + " in the " + std::string(stage_name(sb)) + " stage of the same variant, in " +
                  count_text(together.variants.size());
      } else {
        message += ", in different variants: " + describe(a) + " in " + first_variants(holders(a)) + ", " + describe(b) +
                   " in " + first_variants(holders(b));
      }
      if (!together.variants.empty()) notes.push_back("first in variant [" + in_.variant_names[together.variants.front()] + "]");
      notes.push_back(fix_for_shared_slot(a, b));
    } else {
      message += "'" + a.name + "' is at " + slot_text(a) + " in " + first_variants(holders(a)) + " and at " + slot_text(b) +
                 " in " + first_variants(holders(b));
      notes.push_back("a resource must have one binding in every variant of a pass; one declared without a register "
                      "is bound automatically in declaration order, so a keyword that removes a declaration before it moves "
                      "it: give it a register or [[vk::binding(N, S)]]");
    }
    SourceLocation at = locate(a);
    sink_.report(DiagId::LayoutMismatch, at, message, notes);
    note_other_declaration(DiagId::LayoutMismatch, a, b);
  }

 private:
  // The variants in which some binary holds `a` and another (or the same) holds `b`, and how.
  struct Together {
    std::vector<size_t> variants;
    std::set<std::pair<Stage, Stage>> stage_pairs;  // held by two stages of one variant
    bool same_binary = false;                       // held by one binary
  };
  Together find_together(const Resource& a, const Resource& b) const {
    Together out;
    const std::vector<size_t> holding_a = holders(a), holding_b = holders(b);
    for (size_t v = 0; v < in_.variant_names.size(); ++v) {
      bool found = false;
      for (size_t i : holding_a)
        for (size_t j : holding_b)
          if (uses(i, v) && uses(j, v)) {
            found = true;
            if (i == j) out.same_binary = true;
            else if (in_.binaries[i].stage != in_.binaries[j].stage) out.stage_pairs.emplace(in_.binaries[i].stage, in_.binaries[j].stage);
          }
      if (found) out.variants.push_back(v);
    }
    return out;
  }

  // K1411, a warning: one binding's block (or the push constants) declared with overlapping members that disagree.
  void report_members(const LayoutClash& clash) {
    const Resource& a = clash.first;
    const Resource& b = clash.second;
    std::string message = "pass '" + in_.pass + "': ";
    if (clash.push_constants) {
      message += "its push-constant blocks ('" + a.name + "', '" + b.name + "') declare overlapping members that disagree: " + clash.member;
    } else {
      const Together together = find_together(a, b);
      std::string where = "in different variants";
      if (!together.stage_pairs.empty())
        where = "in the " + std::string(stage_name(together.stage_pairs.begin()->first)) + " and " +
                std::string(stage_name(together.stage_pairs.begin()->second)) + " stages";
      message += "the " + std::string(resource_kind_name(a.kind)) + " at " + slot_text(a) + " (" +
                 (a.name == b.name ? "'" + a.name + "'" : "'" + a.name + "' and '" + b.name + "'") + ") is declared " + where +
                 " with overlapping members that disagree: " + clash.member;
    }
    sink_.report(Diagnostic{DiagId::BlockMemberMismatch, Severity::Warning, clash.push_constants ? in_.pass_location : locate(a), message,
                            {"Vulkan accepts it, but one declaration reads as one type the bytes another declaration writes as "
                             "another: declare the block once, in a file every stage and variant includes"}});
    if (!clash.push_constants) note_other_declaration(DiagId::BlockMemberMismatch, a, b);
  }

  void note_other_declaration(DiagId id, const Resource& a, const Resource& b) {
    if (a.name == b.name || !in_.locate) return;
    SourceLocation other = in_.locate(b.name);
    if (other.line > 0) sink_.report(Diagnostic{id, Severity::Note, other, describe(b) + " is declared here", {}});
  }

  std::vector<size_t> holders(const Resource& resource) const {
    std::vector<size_t> out;
    for (size_t i = 0; i < in_.binaries.size(); ++i)
      if (in_.binaries[i].reflection->holds(resource)) out.push_back(i);
    return out;
  }
  bool uses(size_t binary, size_t variant) const {
    const auto& v = in_.binaries[binary].variants;
    return std::binary_search(v.begin(), v.end(), variant);
  }
  Stage stage_of(const std::vector<size_t>& a, const std::vector<size_t>& b) const {
    for (size_t i : a)
      if (std::find(b.begin(), b.end(), i) != b.end()) return in_.binaries[i].stage;
    return in_.binaries[a.front()].stage;
  }
  // "3 variants, the first [A B]"
  std::string first_variants(const std::vector<size_t>& binaries) const {
    std::set<size_t> variants;
    for (size_t i : binaries) variants.insert(in_.binaries[i].variants.begin(), in_.binaries[i].variants.end());
    if (variants.empty()) return "no variant";
    return count_text(variants.size()) + (variants.size() == 1 ? " [" : ", the first [") + in_.variant_names[*variants.begin()] + "]";
  }
  SourceLocation locate(const Resource& resource) const {
    SourceLocation at = in_.locate ? in_.locate(resource.name) : SourceLocation{};
    return at.line > 0 ? at : in_.pass_location;
  }
  // The shift (a later class moves: b < t < s < u) or attribute that separates the two.
  std::string fix_for_shared_slot(const Resource& a, const Resource& b) const {
    const std::string ca = register_classes(a), cb = register_classes(b);
    const bool texture_and_sampler = (ca == "t" && cb == "s") || (ca == "s" && cb == "t");
    std::string fix;
    if (ca.find_first_of(cb) == std::string::npos) {
      const char moved = std::max(ca.back(), cb.back(), [](char x, char y) { return std::string("btsu").find(x) < std::string("btsu").find(y); });
      uint32_t highest = 0;
      for (const auto& binary : in_.binaries)
        for (const Resource& r : binary.reflection->resources) highest = std::max(highest, r.binding);
      const uint32_t shift = (highest / 16 + 1) * 16;
      const std::string letter(1, moved), space = std::to_string(a.set);
      fix = "registers of different classes share a number: shift one class, e.g. \"bindings\": {\"shifts\": [{\"register\": \"" +
            letter + "\", \"shift\": " + std::to_string(shift) + ", \"space\": " + space + "}]} in the pack definition or --fvk-" +
            letter + "-shift " + std::to_string(shift) + " " + space + " (DXC's -fvk-" + letter + "-shift), or give one of them [[vk::binding(N, " +
            space + ")]]";
    } else {
      fix = "give one of them another register, or [[vk::binding(N, " + std::to_string(a.set) + ")]]";
    }
    if (texture_and_sampler && !in_.combined_image_samplers)
      fix += "; or, if the texture and the sampler are meant as one combined image sampler, set \"combined_image_samplers\": true "
             "(--combined-image-samplers)";
    return fix;
  }

  const PassLayoutInput& in_;
  DiagnosticSink& sink_;
};

}  // namespace

std::optional<PassLayout> check_pass_layout(const PassLayoutInput& input, DiagnosticSink& sink) {
  std::vector<LayoutSource> sources;
  for (const auto& binary : input.binaries) sources.push_back({binary.stage, binary.reflection});
  MergedLayout merged = merge_layouts(sources);
  Checker checker(input, sink);
  // A resource that moved (an automatic binding shifted by an #ifdef before it) makes the slot it left or
  // took look shared too: the move is the root cause, reported alone.
  std::set<std::string> moved;
  for (const LayoutClash& clash : merged.clashes)
    if (clash.kind == LayoutClash::Kind::MovedResource) moved.insert(clash.first.name);
  for (const LayoutClash& clash : merged.clashes) {
    const bool consequence = clash.kind == LayoutClash::Kind::SharedSlot && clash.first.name != clash.second.name &&
                             (moved.count(clash.first.name) || moved.count(clash.second.name));
    if (!consequence) checker.report(clash);
  }
  const bool errors = std::any_of(merged.clashes.begin(), merged.clashes.end(),
                                  [](const LayoutClash& c) { return c.kind != LayoutClash::Kind::MemberMismatch; });
  if (errors) return std::nullopt;
  return std::move(merged.layout);
}

}  // namespace kiln
