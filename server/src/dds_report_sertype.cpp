// SPDX-License-Identifier: Apache-2.0
#include "dds_report_sertype.hpp"

#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>
#include <dds/ddsi/ddsi_typelib.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <new>
#include <type_traits>
#include <utility>

#include "tsan_handoff.hpp"

namespace nearpoint::server {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the report serialiser writes little-endian CDR (Cyclone's native encoding here)");

using ReportSample = nearpoint_msgs_msg_dds__DistanceReport_;
using ReportBatchSample = nearpoint_msgs_msg_dds__DistanceReportBatch_;
using PairSample = nearpoint_msgs_msg_dds__PairDistance_;
using EventSample = nearpoint_msgs_msg_dds__ThresholdEvent_;

/// The encapsulation header: CDR (XCDR1) little endian; the options' low bits are the padding.
constexpr std::size_t kHeaderBytes = 4;

/// One serialised sample: the header and padded payload right after the struct, in one block
/// (the serdata Cyclone holds, sends and releases).
struct ReportSerdata {
  ddsi_serdata c;  // first: Cyclone passes &c and we cast back
  std::uint32_t size;
  unsigned char* bytes() { return reinterpret_cast<unsigned char*>(this + 1); }
  const unsigned char* bytes() const { return reinterpret_cast<const unsigned char*>(this + 1); }
};
constexpr std::size_t kPayloadOffset = sizeof(ReportSerdata) + kHeaderBytes;

/// XCDR1 (classic CDR), little endian: every primitive aligned to its own size, counted from
/// the first byte after the encapsulation header; strings as a uint32 length that counts the
/// terminating NUL, then the bytes and the NUL (a null pointer is the empty string, as Cyclone
/// writes it); sequences as a uint32 count and the elements; fixed arrays as their elements.
///
/// It writes straight into the block that becomes the serdata (malloc'd with room for the
/// ReportSerdata in front), grown by realloc when a sample is larger than the first guess: no
/// sizing pass over the sample, and for a steady stream (the guess is the last sample's size) no
/// copy either.
class CdrOut {
 public:
  explicit CdrOut(std::size_t capacity_guess)
      : capacity_(std::max<std::size_t>(capacity_guess, 256)),
        block_(static_cast<unsigned char*>(std::malloc(kPayloadOffset + capacity_))) {
    if (!block_) capacity_ = 0;
  }
  CdrOut(const CdrOut&) = delete;
  CdrOut& operator=(const CdrOut&) = delete;
  ~CdrOut() { std::free(block_); }

  bool ok() const { return block_ != nullptr; }
  /// Takes the block (finish()'s bytes after the ReportSerdata's room at its start).
  unsigned char* release() { return std::exchange(block_, nullptr); }
  const unsigned char* payload() const { return block_ + kPayloadOffset; }

  // Inlined everywhere, each a few stores. (A report is mostly its pairs: PairCursor writes them.)
  template <class T>
  [[gnu::always_inline]] void put(T value) {
    static_assert(std::is_arithmetic_v<T>);
    if (!reserve(2 * sizeof(T))) return;  // the value and its alignment
    const std::size_t pad = (sizeof(T) - (pos_ & (sizeof(T) - 1))) & (sizeof(T) - 1);
    std::memset(at(), 0, sizeof(T));  // covers the padding (< sizeof(T)): one store, no call
    pos_ += pad;
    std::memcpy(at(), &value, sizeof(T));
    pos_ += sizeof(T);
  }
  [[gnu::always_inline]] void boolean(bool value) { put<std::uint8_t>(value ? 1 : 0); }
  void octets(const void* bytes, std::size_t n) {
    if (!reserve(n)) return;
    std::memcpy(at(), bytes, n);
    pos_ += n;
  }
  void string(const char* text) {
    const std::size_t length = text ? std::strlen(text) : 0;
    put<std::uint32_t>(std::uint32_t(length + 1));
    octets(text ? text : "", length + 1);
  }

  /// Room for `n` more bytes for a writer with its own cursor (PairCursor): the payload's first
  /// byte and the position to write at; false once memory ran out. commit() takes the position
  /// the writer reached (at most `n` further).
  bool claim(std::size_t n, unsigned char*& payload, std::size_t& pos) {
    if (!reserve(n)) return false;
    payload = block_ + kPayloadOffset;
    pos = pos_;
    return true;
  }
  void commit(std::size_t pos) { pos_ = pos; }

  /// The header in front and the zero padding behind the payload (DDSI wants a multiple of 4):
  /// the finished sample's size, its bytes from block + sizeof(ReportSerdata) (0 when memory ran
  /// out).
  std::size_t finish() {
    const std::size_t pad = (4 - (pos_ & 3)) & 3;
    if (!block_ || !reserve(pad)) return 0;
    std::memset(at(), 0, pad);
    unsigned char* header = block_ + sizeof(ReportSerdata);
    header[0] = 0x00;  // CDR_LE
    header[1] = 0x01;
    header[2] = 0x00;  // options, big endian: the padding's length
    header[3] = static_cast<unsigned char>(pad);
    return kHeaderBytes + pos_ + pad;
  }

 private:
  unsigned char* at() { return block_ + kPayloadOffset + pos_; }

  /// Room for `n` more bytes; false once memory ran out (then every later write is skipped,
  /// capacity_ stays 0 and ok() is false).
  [[gnu::always_inline]] bool reserve(std::size_t n) {
    if (pos_ + n <= capacity_) [[likely]]
      return true;
    return grow(n);
  }
  bool grow(std::size_t n) {
    if (!block_) return false;
    const std::size_t grown = std::max(2 * capacity_, pos_ + n);
    auto* moved = static_cast<unsigned char*>(std::realloc(block_, kPayloadOffset + grown));
    if (!moved) {
      std::free(block_);
      block_ = nullptr;
      capacity_ = 0;
      return false;
    }
    block_ = moved;
    capacity_ = grown;
    return true;
  }

  std::size_t capacity_;
  unsigned char* block_;
  std::size_t pos_ = 0;
};

// The fields in .msg order (ros/nearpoint_msgs/msg, ros/standard): the order is the contract.

void write_header(CdrOut& out, const std_msgs_msg_dds__Header_& header) {
  out.put<std::int32_t>(header.stamp.sec);
  out.put<std::uint32_t>(header.stamp.nanosec);
  out.string(header.frame_id);
}

/// CdrOut's writes without its bounds checks, into room claimed for a whole pair, with the
/// position in a local object: a store through unsigned char may alias anything whose address
/// is known elsewhere, so CdrOut's own put() reloads the block and position after every value,
/// while a local the compiler sees whole stays in registers. (A report is 45 pairs of 56
/// values: this was three quarters of the serialiser's time.)
struct PairCursor {
  unsigned char* payload;
  std::size_t pos;

  template <class T>
  [[gnu::always_inline]] void put(T value) {
    static_assert(std::is_arithmetic_v<T>);
    const std::size_t pad = (sizeof(T) - (pos & (sizeof(T) - 1))) & (sizeof(T) - 1);
    std::memset(payload + pos, 0, sizeof(T));  // covers the padding (< sizeof(T))
    pos += pad;
    std::memcpy(payload + pos, &value, sizeof(T));
    pos += sizeof(T);
  }
  [[gnu::always_inline]] void boolean(bool value) { put<std::uint8_t>(value ? 1 : 0); }
  [[gnu::always_inline]] void string(const char* text, std::size_t length) {
    put<std::uint32_t>(std::uint32_t(length + 1));
    if (length > 0) std::memcpy(payload + pos, text, length);
    payload[pos + length] = 0;
    pos += length + 1;
  }
  template <class V>
  [[gnu::always_inline]] void vector(const V& v) {
    put(v.x);
    put(v.y);
    put(v.z);
  }
};

/// The most a pair's values take besides its strings: 53 values, each at most 8 bytes and 7 of
/// padding, and the strings' lengths with theirs (3 × (4 + 3)).
constexpr std::size_t kPairFixedBound = 53 * 15 + 3 * 7;

void write_pair(CdrOut& out, const PairSample& pair) {
  const std::size_t a = pair.object_a ? std::strlen(pair.object_a) : 0;
  const std::size_t b = pair.object_b ? std::strlen(pair.object_b) : 0;
  const std::size_t m = pair.message ? std::strlen(pair.message) : 0;
  PairCursor c{};
  if (!out.claim(kPairFixedBound + a + b + m + 3, c.payload, c.pos)) return;
  c.string(pair.object_a, a);
  c.string(pair.object_b, b);
  c.put<std::uint8_t>(pair.status);
  c.put(pair.distance);
  c.put(pair.distance_lower_bound);
  c.put(pair.error_bound);
  c.put<std::uint32_t>(pair.iterations);
  c.put<std::uint32_t>(pair.piece_pairs_evaluated);
  c.put<std::uint32_t>(pair.piece_a);
  c.put<std::uint32_t>(pair.piece_b);
  c.boolean(pair.warm_started);
  c.boolean(pair.has_near_points);
  c.vector(pair.point_a);
  c.vector(pair.point_b);
  c.vector(pair.normal);
  c.boolean(pair.has_penetration_bound);
  c.put(pair.penetration_bound);
  c.boolean(pair.has_gradient);
  c.vector(pair.gradient_a.translation);
  c.vector(pair.gradient_a.rotation);
  c.vector(pair.gradient_b.translation);
  c.vector(pair.gradient_b.rotation);
  c.string(pair.message, m);
  c.boolean(pair.has_signed_distance);
  c.put(pair.signed_distance);
  c.put(pair.signed_distance_lower);
  c.put(pair.signed_distance_upper);
  c.boolean(pair.has_penetration_depth);
  c.put(pair.penetration_depth);
  c.put(pair.penetration_depth_lower);
  c.put(pair.penetration_depth_upper);
  c.vector(pair.depth_point_a);
  c.vector(pair.depth_point_b);
  c.vector(pair.depth_direction);
  c.put<std::uint8_t>(pair.depth_termination);
  c.put<std::uint32_t>(pair.depth_iterations);
  out.commit(c.pos);
}

void write_event(CdrOut& out, const EventSample& event) {
  write_header(out, event.header);
  out.string(event.scene_id);
  out.string(event.client_id);
  out.string(event.threshold);
  out.put<std::uint32_t>(event.threshold_index);
  out.string(event.object_a);
  out.string(event.object_b);
  out.put<std::uint8_t>(event.crossing);
  out.put(event.distance);
  out.put<std::uint64_t>(event.sequence_number);
}

void write_report(CdrOut& out, const ReportSample& report) {
  write_header(out, report.header);
  out.string(report.scene_id);
  out.string(report.client_id);
  out.octets(report.writer_guid, sizeof report.writer_guid);
  out.put<std::uint64_t>(report.sequence_number);
  out.put<std::uint32_t>(report.status);
  out.string(report.error_field);
  out.string(report.message);
  out.put<std::uint32_t>(report.pairs._length);
  for (std::uint32_t i = 0; i < report.pairs._length; ++i) write_pair(out, report.pairs._buffer[i]);
  out.put(report.timing.server_us);
  out.put(report.timing.queue_us);
  out.put(report.timing.evaluation_us);
  out.put(report.timing.geometry_us);
  out.put<std::uint32_t>(report.coalesced_updates);
  out.put<std::uint64_t>(report.coalesced_from_sequence);
  out.put<std::uint32_t>(report.counts.pairs_evaluated);
  out.put<std::uint32_t>(report.counts.pairs_pruned);
  out.put<std::uint32_t>(report.counts.pairs_unmoved);
  out.put<std::uint8_t>(report.report_mode);
  out.put<std::uint32_t>(report.events._length);
  for (std::uint32_t i = 0; i < report.events._length; ++i)
    write_event(out, report.events._buffer[i]);
}

void write_sample(CdrOut& out, ReportTopicType type, const void* sample) {
  if (type == ReportTopicType::report) {
    write_report(out, *static_cast<const ReportSample*>(sample));
    return;
  }
  const auto& batch = *static_cast<const ReportBatchSample*>(sample);
  out.put<std::uint32_t>(batch.reports._length);
  for (std::uint32_t i = 0; i < batch.reports._length; ++i)
    write_report(out, batch.reports._buffer[i]);
}

// --- The sertype: what Cyclone calls to make, send and release samples of our two topics ---

struct ReportSertype {
  ddsi_sertype c;  // first: Cyclone passes &c and we cast back
  ReportTopicType type;
  const dds_topic_descriptor_t* descriptor;  // the type name, size and XTypes metadata
  /// The last sample's size: the first guess for the next one's block (a stream's reports are
  /// much alike). Relaxed: a stale guess costs one realloc, nothing else.
  mutable std::atomic<std::size_t> size_guess{4096};
};

// A serdata is made on the writing thread, then read (sent, resent) and freed on Cyclone's
// threads, in an order its reference count keeps. That count's atomics run inside libddsc, which
// is not built with TSan, so TSan sees none of that order (tsan_handoff.hpp; every call here is
// empty outside TSan builds). It is told instead: `published` ends the making (the bytes never
// change after), each use is a Use (acquire at its start, release at its end), and the free
// acquires them all. Our own reference counting (reference, unreference) uses the same atomics as
// Cyclone's inline ddsi_serdata_ref/unref but is kept out of TSan's view like Cyclone's own
// calls: instrumented, it would race (for TSan) with a free on another thread that it cannot see
// being ordered by the count. The sertype is shared the same way (made by create_report_topic,
// used by every call here, freed by Cyclone when its last topic and writer are gone).
ddsi_serdata* published(ReportSerdata* d) {
  handoff_release(d);
  return &d->c;
}

template <class T>
class Use {
 public:
  explicit Use(const void* object) : object_(static_cast<const T*>(object)) {
    handoff_acquire(object_);
  }
  ~Use() { handoff_release(object_); }
  Use(const Use&) = delete;
  Use& operator=(const Use&) = delete;
  const T& operator*() const { return *object_; }
  const T* operator->() const { return object_; }

 private:
  const T* object_;
};

[[gnu::no_sanitize_thread]] ddsi_serdata* reference(const ddsi_serdata* d) {
  auto* mutable_d = const_cast<ddsi_serdata*>(d);
  __atomic_fetch_add(&mutable_d->refc.v, 1u, __ATOMIC_SEQ_CST);  // ddsrt_atomic_inc32
  return mutable_d;
}

/// `ref` is Cyclone's: an entry of a message it is building, guarded by its own locks. Written
/// outside TSan's view, as Cyclone's own serdata writes it from inside libddsc.
[[gnu::no_sanitize_thread]] void point_at(ddsrt_iovec_t& ref, const unsigned char* bytes,
                                          std::size_t size) {
  ref.iov_base = const_cast<unsigned char*>(bytes);
  ref.iov_len = static_cast<ddsrt_iov_len_t>(size);
}

[[gnu::no_sanitize_thread]] void unreference(ddsi_serdata* d) {
  if (__atomic_fetch_sub(&d->refc.v, 1u, __ATOMIC_SEQ_CST) == 1)  // ddsrt_atomic_dec32_ov
    d->ops->free(d);
}

/// The serdata in `block` (malloc'd, at least sizeof(ReportSerdata) + size bytes), which it
/// now owns; null (and the block freed) when the sample is too large for DDSI.
ReportSerdata* make_serdata(void* block, const ddsi_sertype* type, ddsi_serdata_kind kind,
                            std::size_t size) {
  if (size > UINT32_MAX) {  // DDSI cannot carry it; dds_write reports the failure
    std::free(block);
    return nullptr;
  }
  auto* d = new (block) ReportSerdata;
  ddsi_serdata_init(&d->c, type, kind);
  d->c.hash = Use<ddsi_sertype>(type)->serdata_basehash;  // keyless: one instance, one hash
  d->size = std::uint32_t(size);
  return d;
}

ReportSerdata* new_serdata(const ddsi_sertype* type, ddsi_serdata_kind kind, std::size_t size) {
  void* block = std::malloc(sizeof(ReportSerdata) + size);
  return block ? make_serdata(block, type, kind, size) : nullptr;
}

/// A keyless sample's key: the header alone (Cyclone needs one for dispose, unregister and the
/// instance map even on a topic without instances).
/// `untyped`: without a type, as Cyclone's instance map keeps keys (to_untyped).
ddsi_serdata* key_only(const ddsi_sertype* type, ddsi_serdata_kind kind, bool untyped = false) {
  ReportSerdata* d = new_serdata(type, kind, kHeaderBytes);
  if (!d) return nullptr;
  const unsigned char header[kHeaderBytes] = {0x00, 0x01, 0x00, 0x00};
  std::memcpy(d->bytes(), header, kHeaderBytes);
  if (untyped) d->c.type = nullptr;
  return published(d);
}

ddsi_serdata* serdata_from_sample(const ddsi_sertype* type, ddsi_serdata_kind kind,
                                  const void* sample) {
  if (kind != SDK_DATA) return key_only(type, kind);
  const Use<ReportSertype> ours(type);
  CdrOut out(ours->size_guess.load(std::memory_order_relaxed));
  write_sample(out, ours->type, sample);
  const std::size_t size = out.finish();
  if (!out.ok()) return nullptr;  // out of memory
  ours->size_guess.store(size, std::memory_order_relaxed);
  ReportSerdata* d = make_serdata(out.release(), type, kind, size);
  return d ? published(d) : nullptr;
}

/// A copy of bytes received or converted (Cyclone only does this for readers of our sertype,
/// which nearpoint never creates; kept so that the sertype is complete).
ddsi_serdata* serdata_from_ser_iov(const ddsi_sertype* type, ddsi_serdata_kind kind,
                                   ddsrt_msg_iovlen_t niov, const ddsrt_iovec_t* iov,
                                   std::size_t size) {
  ReportSerdata* d = new_serdata(type, kind, size);
  if (!d) return nullptr;
  std::size_t at = 0;
  for (ddsrt_msg_iovlen_t i = 0; i < niov && at < size; ++i) {
    const std::size_t n = std::min<std::size_t>(iov[i].iov_len, size - at);
    std::memcpy(d->bytes() + at, iov[i].iov_base, n);
    at += n;
  }
  std::memset(d->bytes() + at, 0, size - at);
  return published(d);
}

ddsi_serdata* serdata_from_ser(const ddsi_sertype* type, ddsi_serdata_kind kind,
                               const nn_rdata* fragchain, std::size_t size) {
  // Received fragments are only delivered to readers, and nearpoint has none of this sertype.
  (void)type, (void)kind, (void)fragchain, (void)size;
  return nullptr;
}

ddsi_serdata* serdata_from_keyhash(const ddsi_sertype* type, const ddsi_keyhash* keyhash) {
  (void)keyhash;
  return key_only(type, SDK_KEY);
}

std::uint32_t serdata_size(const ddsi_serdata* d) {
  return Use<ReportSerdata>(d)->size;
}

void serdata_to_ser(const ddsi_serdata* d, std::size_t off, std::size_t sz, void* buf) {
  const Use<ReportSerdata> use(d);
  std::memcpy(buf, use->bytes() + off, sz);
}

ddsi_serdata* serdata_to_ser_ref(const ddsi_serdata* d, std::size_t off, std::size_t sz,
                                 ddsrt_iovec_t* ref) {
  const Use<ReportSerdata> use(d);  // the reader of `ref` is Cyclone's (uninstrumented) code
  point_at(*ref, use->bytes() + off, sz);
  return reference(d);
}

void serdata_to_ser_unref(ddsi_serdata* d, const ddsrt_iovec_t* ref) {
  (void)ref;
  { const Use<ReportSerdata> use(d); }  // this thread's use of the bytes ends here
  unreference(d);
}

bool serdata_to_sample(const ddsi_serdata* d, void* sample, void** bufptr, void* buflim) {
  // Write-only: a reader takes these samples through its own (idlc) type, converted from bytes.
  (void)d, (void)sample, (void)bufptr, (void)buflim;
  return false;
}

ddsi_serdata* serdata_to_untyped(const ddsi_serdata* d) {
  const ddsi_sertype* type = Use<ReportSerdata>(d)->c.type;
  return key_only(type, SDK_KEY, true);
}

bool serdata_untyped_to_sample(const ddsi_sertype* type, const ddsi_serdata* d, void* sample,
                               void** bufptr, void* buflim) {
  (void)type, (void)d, (void)sample, (void)bufptr, (void)buflim;
  return true;  // no key fields to fill
}

bool serdata_eqkey(const ddsi_serdata* a, const ddsi_serdata* b) {
  (void)a, (void)b;
  return true;  // keyless: every sample is the one instance
}

void serdata_free(ddsi_serdata* d) {
  handoff_acquire(d);  // after every Use, and the making
  auto* serdata = reinterpret_cast<ReportSerdata*>(d);
  serdata->~ReportSerdata();
  std::free(serdata);
}

std::size_t serdata_print(const ddsi_sertype* type, const ddsi_serdata* d, char* buf,
                          std::size_t size) {
  const char* name = type ? Use<ddsi_sertype>(type)->type_name : "nearpoint report";
  const int n = std::snprintf(buf, size, "(%s, %u bytes of CDR)", name, serdata_size(d));
  return n < 0 ? 0 : std::size_t(n);
}

void serdata_get_keyhash(const ddsi_serdata* d, ddsi_keyhash* buf, bool force_md5) {
  (void)d, (void)force_md5;
  std::memset(buf->value, 0, sizeof buf->value);
}

const ddsi_serdata_ops kSerdataOps = [] {
  ddsi_serdata_ops ops{};
  ops.eqkey = serdata_eqkey;
  ops.get_size = serdata_size;
  ops.from_ser = serdata_from_ser;
  ops.from_ser_iov = serdata_from_ser_iov;
  ops.from_keyhash = serdata_from_keyhash;
  ops.from_sample = serdata_from_sample;
  ops.to_ser = serdata_to_ser;
  ops.to_ser_ref = serdata_to_ser_ref;
  ops.to_ser_unref = serdata_to_ser_unref;
  ops.to_sample = serdata_to_sample;
  ops.to_untyped = serdata_to_untyped;
  ops.untyped_to_sample = serdata_untyped_to_sample;
  ops.free = serdata_free;
  ops.print = serdata_print;
  ops.get_keyhash = serdata_get_keyhash;
  return ops;  // no shared-memory (iceoryx) ops: nearpoint's configurations never enable it
}();

void sertype_free(ddsi_sertype* type) {
  handoff_acquire(type);  // after every Use (see published), and the making
  auto* ours = reinterpret_cast<ReportSertype*>(type);
  ddsi_sertype_fini(&ours->c);
  delete ours;
}

// Samples of this sertype are only ever the caller's (dds_write's argument): Cyclone allocates
// them only for readers and loans, which this write-only type never has. These keep the
// interface's contract for plain structs all the same.
void sertype_zero_samples(const ddsi_sertype* type, void* samples, std::size_t count) {
  std::memset(samples, 0, Use<ReportSertype>(type)->descriptor->m_size * count);
}

void sertype_realloc_samples(void** ptrs, const ddsi_sertype* type, void* old, std::size_t oldcount,
                             std::size_t count) {
  const std::size_t size = Use<ReportSertype>(type)->descriptor->m_size;
  char* grown = static_cast<char*>(
      old == nullptr || oldcount != count ? dds_realloc(old, size * count) : old);
  if (grown && count > oldcount) std::memset(grown + size * oldcount, 0, size * (count - oldcount));
  for (std::size_t i = 0; i < count; ++i) ptrs[i] = grown + i * size;
}

void sertype_free_samples(const ddsi_sertype* type, void** ptrs, std::size_t count,
                          dds_free_op_t op) {
  (void)type;
  if (count > 0 && (op & DDS_FREE_ALL_BIT)) dds_free(ptrs[0]);
}

bool sertype_equal(const ddsi_sertype* a, const ddsi_sertype* b) {
  return Use<ReportSertype>(a)->descriptor == Use<ReportSertype>(b)->descriptor;
}

std::uint32_t sertype_hash(const ddsi_sertype* type) {
  return std::uint32_t(std::hash<const void*>{}(Use<ReportSertype>(type)->descriptor));
}

// The XTypes metadata, read from the descriptor as Cyclone's default sertype reads it.
ddsi_sertype_cdr_data_t metadata(const dds_type_meta_ser& blob) {
  return {blob.sz, blob.data};
}

bool has_xtypes_metadata(const ddsi_sertype* type) {
  return (Use<ReportSertype>(type)->descriptor->m_flagset & DDS_TOPIC_XTYPES_METADATA) != 0;
}

ddsi_typeinfo_t* sertype_typeinfo(const ddsi_sertype* type) {
  if (!has_xtypes_metadata(type)) return nullptr;
  const ddsi_sertype_cdr_data_t blob =
      metadata(Use<ReportSertype>(type)->descriptor->type_information);
  return ddsi_typeinfo_deser(&blob);
}

ddsi_typemap_t* sertype_typemap(const ddsi_sertype* type) {
  if (!has_xtypes_metadata(type)) return nullptr;
  const ddsi_sertype_cdr_data_t blob = metadata(Use<ReportSertype>(type)->descriptor->type_mapping);
  return ddsi_typemap_deser(&blob);
}

ddsi_typeid_t* sertype_typeid(const ddsi_sertype* type, ddsi_typeid_kind_t kind) {
  ddsi_typeinfo_t* info = sertype_typeinfo(type);
  if (!info) return nullptr;
  ddsi_typeid_t* id = ddsi_typeinfo_typeid(info, kind);
  ddsi_typeinfo_fini(info);
  dds_free(info);
  return id;
}

const ddsi_sertype_ops kSertypeOps = [] {
  ddsi_sertype_ops ops{};
  ops.version = ddsi_sertype_v0;
  ops.free = sertype_free;
  ops.zero_samples = sertype_zero_samples;
  ops.realloc_samples = sertype_realloc_samples;
  ops.free_samples = sertype_free_samples;
  ops.equal = sertype_equal;
  ops.hash = sertype_hash;
  ops.type_id = sertype_typeid;
  ops.type_map = sertype_typemap;
  ops.type_info = sertype_typeinfo;
  // No derive_sertype: a writer uses the topic's sertype as it is (XCDR1, see
  // create_report_topic).
  return ops;
}();

const dds_topic_descriptor_t& descriptor_of(ReportTopicType type) {
  return type == ReportTopicType::report ? nearpoint_msgs_msg_dds__DistanceReport__desc
                                         : nearpoint_msgs_msg_dds__DistanceReportBatch__desc;
}

std::vector<unsigned char> serialise(ReportTopicType type, const void* sample) {
  CdrOut out(0);
  write_sample(out, type, sample);
  const std::size_t size = out.finish();
  if (!out.ok()) throw std::bad_alloc();
  const unsigned char* bytes = out.payload() - kHeaderBytes;
  return std::vector<unsigned char>(bytes, bytes + size);
}

}  // namespace

dds_entity_t create_report_topic(dds_entity_t participant, ReportTopicType type, const char* name,
                                 const dds_qos_t* qos) {
  auto* ours = new ReportSertype{};
  ours->type = type;
  ours->descriptor = &descriptor_of(type);
  ddsi_sertype_init_flags(&ours->c, ours->descriptor->m_typename, &kSertypeOps, &kSerdataOps,
                          DDSI_SERTYPE_FLAG_TOPICKIND_NO_KEY);
  // What dds_create_topic allows for these (final) types, so that the topic's QoS is the one
  // every other participant's topic of this name has (a differing one is an inconsistent
  // topic). The writers still write XCDR1 only: a writer takes the first representation of its
  // QoS, which is XCDR1 unless its QoS names another, and the bridge's never does (ROS 2 needs
  // XCDR1).
  ours->c.allowed_data_representation = DDS_DATA_REPRESENTATION_RESTRICT_DEFAULT;
  handoff_release(ours);  // made: Cyclone's threads use it from now on (see published)
  ddsi_sertype* sertype = &ours->c;
  const dds_entity_t topic =
      dds_create_topic_sertype(participant, name, &sertype, qos, nullptr, nullptr);
  if (topic < 0) ddsi_sertype_unref(sertype);  // as dds_create_topic does on failure
  return topic;
}

std::vector<unsigned char> serialise_report(const ReportSample& sample) {
  return serialise(ReportTopicType::report, &sample);
}

std::vector<unsigned char> serialise_report_batch(const ReportBatchSample& sample) {
  return serialise(ReportTopicType::report_batch, &sample);
}

}  // namespace nearpoint::server
