// SPDX-License-Identifier: Apache-2.0
#include "wire_parse.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/unknown_field_set.h>

#include "nearpoint/server/errors.hpp"

namespace nearpoint::server {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::UnknownField;
using google::protobuf::UnknownFieldSet;

/// Protobuf's default recursion limit: a parse nested deeper fails.
constexpr int kMaxDepth = 100;

/// Strict UTF-8 (what protobuf requires of proto3 strings): no overlong forms, no surrogates,
/// nothing above U+10FFFF.
bool valid_utf8(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t extra = 0;
    unsigned long code = 0, minimum = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xE0) == 0xC0) {
      extra = 1, code = c & 0x1F, minimum = 0x80;
    } else if ((c & 0xF0) == 0xE0) {
      extra = 2, code = c & 0x0F, minimum = 0x800;
    } else if ((c & 0xF8) == 0xF0) {
      extra = 3, code = c & 0x07, minimum = 0x10000;
    } else {
      return false;
    }
    if (i + extra >= s.size()) return false;  // truncated sequence
    for (std::size_t k = 1; k <= extra; ++k) {
      const auto next = static_cast<unsigned char>(s[i + k]);
      if ((next & 0xC0) != 0x80) return false;
      code = (code << 6) | (next & 0x3F);
    }
    if (code < minimum || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return false;
    i += extra + 1;
  }
  return true;
}

/// The first field of `fields` (parsed as `type`) to blame, or "".
std::string blame(const Descriptor& type, const UnknownFieldSet& fields, const std::string& path,
                  int depth) {
  if (depth > kMaxDepth)
    return text("messages nest deeper than ", kMaxDepth, " levels (at ", path, ")");
  for (int i = 0; i < fields.field_count(); ++i) {
    const UnknownField& field = fields.field(i);
    const FieldDescriptor* declared = type.FindFieldByNumber(field.number());
    if (declared == nullptr) continue;  // unknown fields are skipped by the parser: not to blame
    const std::string name = path.empty() ? declared->name() : path + "." + declared->name();
    if (field.type() != UnknownField::TYPE_LENGTH_DELIMITED) continue;
    if (declared->type() == FieldDescriptor::TYPE_STRING && !valid_utf8(field.length_delimited()))
      return text("field ", name, " is not valid UTF-8");
    if (declared->type() == FieldDescriptor::TYPE_MESSAGE) {
      UnknownFieldSet inner;
      if (!inner.ParseFromString(field.length_delimited()))
        return text("field ", name, " is not a valid ", declared->message_type()->full_name(),
                    " (not protobuf wire format, or nested deeper than ", kMaxDepth, " levels)");
      if (std::string why = blame(*declared->message_type(), inner, name, depth + 1); !why.empty())
        return why;
    }
  }
  return "";
}

}  // namespace

std::string why_unparsable(const void* data, int size, const Descriptor& type) {
  UnknownFieldSet fields;
  if (!fields.ParseFromArray(data, size))
    return text("the ", size,
                " bytes are not protobuf wire format, or nest groups or messages deeper than ",
                kMaxDepth, " levels");
  if (std::string why = blame(type, fields, "", 1); !why.empty()) return why;
  return "protobuf rejected it without a reason we can name";
}

std::string parse_message(const grpc::ByteBuffer& bytes, google::protobuf::Message& message) {
  grpc::Slice slice;  // empty when the message is (a zero-length payload may have no buffer)
  if (bytes.Valid() && !bytes.DumpToSingleSlice(&slice).ok())
    return "the message's bytes could not be read";
  return parse_message(slice, message);
}

std::string parse_message(const grpc::Slice& slice, google::protobuf::Message& message) {
  const int size = static_cast<int>(slice.size());  // below the receive limit, which is an int
  if (message.ParseFromArray(slice.begin(), size)) return "";
  message.Clear();
  return text("does not parse as ", message.GetTypeName(), ": ",
              why_unparsable(slice.begin(), size, *message.GetDescriptor()));
}

}  // namespace nearpoint::server
