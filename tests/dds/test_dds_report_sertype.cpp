// SPDX-License-Identifier: Apache-2.0
// The report topics' own serialiser (server/src/dds_report_sertype.hpp) and `nearpoint dds
// load`'s reader of report bytes (client/src/dds_report_view.hpp) against Cyclone DDS's:
// for random reports and batches (empty and long strings, null pointers, NaN, infinities, every
// sequence length from none up), the bytes we write must be the bytes Cyclone's generic writer
// makes of the same sample from the idlc descriptor, header and padding included. Then the real
// path: dds_write on a topic made by create_report_topic, a reader of the ordinary idlc type on
// the same participant, dds_takecdr (the bytes a remote reader gets) and dds_take (the sample it
// decodes). The load's reader must find in Cyclone's bytes the fields the sample holds, and
// refuse every truncation of them.
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_typelib.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "dds_report_sertype.hpp"
#include "dds_report_view.hpp"
#include "dds_test_support.hpp"
#include "nearpoint_dds.hpp"

namespace {

using nearpoint::dds_testing::kDomainReportSertype;
using nearpoint::dds_testing::unique_prefix;
using nearpoint::server::create_report_topic;
using nearpoint::server::ReportTopicType;
using nearpoint::server::serialise_report;
using nearpoint::server::serialise_report_batch;
using ReportSample = nearpoint_msgs_msg_dds__DistanceReport_;
using ReportBatchSample = nearpoint_msgs_msg_dds__DistanceReportBatch_;
using PairSample = nearpoint_msgs_msg_dds__PairDistance_;
using EventSample = nearpoint_msgs_msg_dds__ThresholdEvent_;
using Bytes = std::vector<std::uint8_t>;

/// Random samples whose strings and sequences live as long as the generator.
class RandomReports {
 public:
  explicit RandomReports(std::uint32_t seed) : rng_(seed) {}

  ReportSample report() {
    ReportSample r{};
    header(r.header);
    r.scene_id = text();
    r.client_id = text();
    for (auto& byte : r.writer_guid) byte = std::uint8_t(rng_());
    r.sequence_number = rng_();
    r.status = std::uint32_t(rng_() % 16);
    r.error_field = text();
    r.message = text();
    auto& pairs = pair_store_.emplace_back(count(60));
    for (PairSample& p : pairs) pair(p);
    r.pairs._buffer = pairs.empty() ? nullptr : pairs.data();
    r.pairs._length = r.pairs._maximum = std::uint32_t(pairs.size());
    r.timing = {number(), number(), number(), number()};
    r.coalesced_updates = std::uint32_t(rng_());
    r.coalesced_from_sequence = rng_();
    r.counts = {std::uint32_t(rng_()), std::uint32_t(rng_()), std::uint32_t(rng_())};
    r.report_mode = std::uint8_t(rng_());
    auto& events = event_store_.emplace_back(count(4));
    for (EventSample& e : events) event(e);
    r.events._buffer = events.empty() ? nullptr : events.data();
    r.events._length = r.events._maximum = std::uint32_t(events.size());
    return r;
  }

  ReportBatchSample batch() {
    auto& reports = report_store_.emplace_back(count(6));
    for (ReportSample& r : reports) r = report();
    ReportBatchSample b{};
    b.reports._buffer = reports.empty() ? nullptr : reports.data();
    b.reports._length = b.reports._maximum = std::uint32_t(reports.size());
    return b;
  }

 private:
  std::size_t count(std::size_t most) { return rng_() % (most + 1); }
  bool flag() { return rng_() & 1; }

  /// Mostly ordinary values; now and then the ones a serialiser might mangle.
  double number() {
    switch (rng_() % 8) {
      case 0:
        return std::numeric_limits<double>::quiet_NaN();
      case 1:
        return -std::numeric_limits<double>::infinity();
      case 2:
        return -0.0;
      case 3:
        return std::numeric_limits<double>::denorm_min();
      default:
        return std::uniform_real_distribution<double>(-1e3, 1e3)(rng_);
    }
  }

  /// Null, empty, short or long (past any small-buffer size), of any printable bytes.
  char* text() {
    switch (rng_() % 6) {
      case 0:
        return nullptr;
      case 1:
        return strings_.emplace_back().data();
      default:
        break;
    }
    std::string& s = strings_.emplace_back(count(rng_() % 4 == 0 ? 300 : 12), 'x');
    for (char& c : s) c = char(' ' + rng_() % 95);
    return s.data();
  }

  void header(std_msgs_msg_dds__Header_& h) {
    h.stamp.sec = std::int32_t(rng_());
    h.stamp.nanosec = std::uint32_t(rng_());
    h.frame_id = text();
  }

  template <class V>
  void vector(V& v) {
    v.x = number();
    v.y = number();
    v.z = number();
  }

  void pair(PairSample& p) {
    p = PairSample{};
    p.object_a = text();
    p.object_b = text();
    p.status = std::uint8_t(rng_());
    p.distance = number();
    p.distance_lower_bound = number();
    p.error_bound = number();
    p.iterations = std::uint32_t(rng_());
    p.piece_pairs_evaluated = std::uint32_t(rng_());
    p.piece_a = std::uint32_t(rng_());
    p.piece_b = std::uint32_t(rng_());
    p.warm_started = flag();
    p.has_near_points = flag();
    vector(p.point_a);
    vector(p.point_b);
    vector(p.normal);
    p.has_penetration_bound = flag();
    p.penetration_bound = number();
    p.has_gradient = flag();
    vector(p.gradient_a.translation);
    vector(p.gradient_a.rotation);
    vector(p.gradient_b.translation);
    vector(p.gradient_b.rotation);
    p.message = text();
    p.has_signed_distance = flag();
    p.signed_distance = number();
    p.signed_distance_lower = number();
    p.signed_distance_upper = number();
    p.has_penetration_depth = flag();
    p.penetration_depth = number();
    p.penetration_depth_lower = number();
    p.penetration_depth_upper = number();
    vector(p.depth_point_a);
    vector(p.depth_point_b);
    vector(p.depth_direction);
    p.depth_termination = std::uint8_t(rng_());
    p.depth_iterations = std::uint32_t(rng_());
  }

  void event(EventSample& e) {
    e = EventSample{};
    header(e.header);
    e.scene_id = text();
    e.client_id = text();
    e.threshold = text();
    e.threshold_index = std::uint32_t(rng_());
    e.object_a = text();
    e.object_b = text();
    e.crossing = std::uint8_t(rng_());
    e.distance = number();
    e.sequence_number = rng_();
  }

  std::mt19937_64 rng_;
  std::deque<std::string> strings_;  // a deque: growing it moves no string
  std::deque<std::vector<PairSample>> pair_store_;
  std::deque<std::vector<EventSample>> event_store_;
  std::deque<std::vector<ReportSample>> report_store_;
};

/// Two topics of one type on one participant, each with a reader of the idlc type: one made by
/// dds_create_topic (Cyclone serialises), one by create_report_topic (we do).
class Topics {
 public:
  explicit Topics(ReportTopicType type) {
    participant_ = dds_create_participant(kDomainReportSertype, nullptr, nullptr);
    EXPECT_GT(participant_, 0) << dds_strretcode(participant_);
    const nearpoint::dds::QosPtr qos = nearpoint::dds::stream_qos();
    const dds_topic_descriptor_t* descriptor =
        type == ReportTopicType::report ? &nearpoint_msgs_msg_dds__DistanceReport__desc
                                        : &nearpoint_msgs_msg_dds__DistanceReportBatch__desc;
    const std::string prefix = unique_prefix(type == ReportTopicType::report ? "r" : "b");
    const dds_entity_t cyclone = dds_create_topic(participant_, descriptor,
                                                  (prefix + "cyclone").c_str(), qos.get(), nullptr);
    const dds_entity_t ours =
        create_report_topic(participant_, type, (prefix + "ours").c_str(), qos.get());
    EXPECT_GT(cyclone, 0) << dds_strretcode(cyclone);
    EXPECT_GT(ours, 0) << dds_strretcode(ours);
    // A reader of our topic's name with the ordinary idlc type, as every client has.
    const dds_entity_t ours_as_idlc =
        dds_create_topic(participant_, descriptor, (prefix + "ours").c_str(), qos.get(), nullptr);
    EXPECT_GT(ours_as_idlc, 0) << dds_strretcode(ours_as_idlc);
    cyclone_writer_ = dds_create_writer(participant_, cyclone, qos.get(), nullptr);
    cyclone_reader_ = dds_create_reader(participant_, cyclone, qos.get(), nullptr);
    our_writer_ = dds_create_writer(participant_, ours, qos.get(), nullptr);
    our_reader_ = dds_create_reader(participant_, ours_as_idlc, qos.get(), nullptr);
    EXPECT_GT(cyclone_writer_, 0);
    EXPECT_GT(cyclone_reader_, 0);
    EXPECT_GT(our_writer_, 0) << dds_strretcode(our_writer_);
    EXPECT_GT(our_reader_, 0) << dds_strretcode(our_reader_);
  }
  ~Topics() { dds_delete(participant_); }

  /// The bytes a reader gets of `sample` written by Cyclone's serialiser or by ours.
  Bytes by_cyclone(const void* sample) {
    return round_trip(cyclone_writer_, cyclone_reader_, sample);
  }
  Bytes by_us(const void* sample) { return round_trip(our_writer_, our_reader_, sample); }

  /// `sample` written on our topic and taken, decoded, by the idlc reader; `check` inspects it.
  template <class Sample, class Check>
  void decoded(const Sample& sample, Check check) {
    ASSERT_EQ(dds_write(our_writer_, &sample), DDS_RETCODE_OK);
    void* samples[1] = {nullptr};
    dds_sample_info_t info;
    ASSERT_EQ(dds_take(our_reader_, samples, &info, 1, 1), 1);
    ASSERT_TRUE(info.valid_data);
    check(*static_cast<const Sample*>(samples[0]));
    dds_return_loan(our_reader_, samples, 1);
  }

 private:
  static Bytes round_trip(dds_entity_t writer, dds_entity_t reader, const void* sample) {
    EXPECT_EQ(dds_write(writer, sample), DDS_RETCODE_OK);
    ddsi_serdata* data = nullptr;
    dds_sample_info_t info;
    EXPECT_EQ(dds_takecdr(reader, &data, 1, &info, 0), 1);
    if (data == nullptr) return {};
    Bytes out(ddsi_serdata_size(data));
    ddsi_serdata_to_ser(data, 0, out.size(), out.data());
    ddsi_serdata_unref(data);
    return out;
  }

  dds_entity_t participant_ = 0;
  dds_entity_t cyclone_writer_ = 0, cyclone_reader_ = 0, our_writer_ = 0, our_reader_ = 0;
};

Bytes bytes_of(const std::vector<unsigned char>& v) {
  return Bytes(v.begin(), v.end());
}

TEST(DdsReportSertype, ReportsAreTheBytesCycloneWrites) {
  Topics topics(ReportTopicType::report);
  RandomReports random(20261205);
  for (int i = 0; i < 300; ++i) {
    const ReportSample sample = random.report();
    const Bytes cyclone = topics.by_cyclone(&sample);
    ASSERT_FALSE(cyclone.empty());
    ASSERT_EQ(bytes_of(serialise_report(sample)), cyclone) << "sample " << i;
    ASSERT_EQ(topics.by_us(&sample), cyclone) << "sample " << i << ", through a writer";
  }
}

TEST(DdsReportSertype, BatchesAreTheBytesCycloneWrites) {
  Topics topics(ReportTopicType::report_batch);
  RandomReports random(5122026);
  for (int i = 0; i < 100; ++i) {
    const ReportBatchSample sample = random.batch();
    const Bytes cyclone = topics.by_cyclone(&sample);
    ASSERT_FALSE(cyclone.empty());
    ASSERT_EQ(bytes_of(serialise_report_batch(sample)), cyclone) << "batch " << i;
    ASSERT_EQ(topics.by_us(&sample), cyclone) << "batch " << i << ", through a writer";
  }
}

// The encapsulation header, for string lengths that leave the payload at every offset mod 8:
// CDR little endian, and options 0 (both types end in a uint32 count, so a payload is always a
// multiple of 4 and never padded).
TEST(DdsReportSertype, TheHeaderIsLittleEndianCdrWhateverTheStringsLength) {
  Topics topics(ReportTopicType::report);
  for (std::size_t length = 0; length < 8; ++length) {
    const std::string message(length, 'm');
    ReportSample sample{};
    sample.message = const_cast<char*>(message.c_str());
    const Bytes ours = bytes_of(serialise_report(sample));
    ASSERT_EQ(ours, topics.by_cyclone(&sample)) << "message length " << length;
    ASSERT_GE(ours.size(), 4u);
    EXPECT_EQ(Bytes(ours.begin(), ours.begin() + 4), (Bytes{0x00, 0x01, 0x00, 0x00}));
    EXPECT_EQ(ours.size() % 4, 0u);
  }
}

TEST(DdsReportSertype, AReaderOfTheIdlcTypeDecodesWhatWasWritten) {
  Topics topics(ReportTopicType::report_batch);
  RandomReports random(42);
  ReportBatchSample sample = random.batch();
  while (sample.reports._length == 0 || sample.reports._buffer[0].pairs._length == 0)
    sample = random.batch();
  topics.decoded(sample, [&](const ReportBatchSample& got) {
    ASSERT_EQ(got.reports._length, sample.reports._length);
    // Decoded and serialised again, it is the same sample, field for field.
    EXPECT_EQ(serialise_report_batch(got), serialise_report_batch(sample));
    const PairSample& first = got.reports._buffer[0].pairs._buffer[0];
    const PairSample& sent = sample.reports._buffer[0].pairs._buffer[0];
    EXPECT_STREQ(first.object_a, sent.object_a ? sent.object_a : "");
    if (std::isnan(sent.distance))
      EXPECT_TRUE(std::isnan(first.distance));
    else
      EXPECT_EQ(first.distance, sent.distance);
  });
}

// Writers on our topics match readers of the idlc type through XTypes type information, as
// writers on dds_create_topic's do: the type information comes from the same descriptor.
TEST(DdsReportSertype, TheTopicCarriesTheDescriptorsTypeInformation) {
  const dds_entity_t participant = dds_create_participant(kDomainReportSertype, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  const std::string prefix = unique_prefix("typeinfo");
  const dds_entity_t ours =
      create_report_topic(participant, ReportTopicType::report, (prefix + "ours").c_str(), nullptr);
  const dds_entity_t cyclone =
      dds_create_topic(participant, &nearpoint_msgs_msg_dds__DistanceReport__desc,
                       (prefix + "cyclone").c_str(), nullptr, nullptr);
  ASSERT_GT(ours, 0);
  ASSERT_GT(cyclone, 0);
  dds_typeinfo_t* our_info = nullptr;
  dds_typeinfo_t* cyclone_info = nullptr;
  ASSERT_EQ(dds_get_typeinfo(ours, &our_info), DDS_RETCODE_OK);
  ASSERT_EQ(dds_get_typeinfo(cyclone, &cyclone_info), DDS_RETCODE_OK);
  EXPECT_TRUE(ddsi_typeinfo_equal(our_info, cyclone_info, DDSI_TYPE_INCLUDE_DEPS));
  dds_free_typeinfo(our_info);
  dds_free_typeinfo(cyclone_info);
  char name[256];
  ASSERT_GE(dds_get_type_name(ours, name, sizeof name), 0);
  EXPECT_STREQ(name, nearpoint::dds::kDistanceReportType);
  dds_delete(participant);
}

}  // namespace

namespace {

using nearpoint::cli::read_report_views;
using nearpoint::cli::ReportView;

// What a load reads of `sample`, field by field.
void expect_view_of(const ReportView& view, const ReportSample& sample) {
  EXPECT_TRUE(std::equal(view.writer_guid.begin(), view.writer_guid.end(), sample.writer_guid));
  EXPECT_EQ(view.sequence_number, sample.sequence_number);
  EXPECT_EQ(view.status, sample.status);
  EXPECT_EQ(view.message, sample.status != 0 && sample.message ? sample.message : "");
  EXPECT_EQ(view.pair_count, sample.pairs._length);
  // NaN equal to NaN: the timing fields are random doubles here.
  auto same = [](double a, double b) { return std::isnan(a) ? std::isnan(b) : a == b; };
  EXPECT_TRUE(same(view.server_us, sample.timing.server_us)) << view.server_us;
  EXPECT_TRUE(same(view.geometry_us, sample.timing.geometry_us)) << view.geometry_us;
  EXPECT_EQ(view.coalesced_updates, sample.coalesced_updates);
  EXPECT_EQ(view.coalesced_from_sequence, sample.coalesced_from_sequence);
}

std::vector<ReportView> views_of(const Bytes& bytes, bool batch, bool& ok, std::string& error) {
  std::vector<ReportView> views;
  ok = read_report_views(
      bytes.data(), bytes.size(), batch, [&](const ReportView& view) { views.push_back(view); },
      error);
  return views;
}

TEST(DdsReportView, ReadsWhatTheSampleHoldsFromTheBytesAReaderGets) {
  Topics topics(ReportTopicType::report);
  RandomReports random(7);
  for (int i = 0; i < 200; ++i) {
    const ReportSample sample = random.report();
    bool ok = false;
    std::string error;
    const std::vector<ReportView> views = views_of(topics.by_cyclone(&sample), false, ok, error);
    ASSERT_TRUE(ok) << "sample " << i << ": " << error;
    ASSERT_EQ(views.size(), 1u);
    expect_view_of(views[0], sample);
  }
}

TEST(DdsReportView, ReadsEveryReportOfABatch) {
  Topics topics(ReportTopicType::report_batch);
  RandomReports random(8);
  for (int i = 0; i < 60; ++i) {
    const ReportBatchSample sample = random.batch();
    bool ok = false;
    std::string error;
    const std::vector<ReportView> views = views_of(topics.by_cyclone(&sample), true, ok, error);
    ASSERT_TRUE(ok) << "batch " << i << ": " << error;
    ASSERT_EQ(views.size(), sample.reports._length);
    for (std::size_t k = 0; k < views.size(); ++k)
      expect_view_of(views[k], sample.reports._buffer[k]);
  }
}

// Every strict prefix of a report is refused (the payload is never padded: see the header
// test), with a reason, and delivers nothing; a batch's prefix delivers only whole reports.
TEST(DdsReportView, RefusesEveryTruncationAndAnotherEncoding) {
  Topics topics(ReportTopicType::report_batch);
  RandomReports random(9);
  ReportBatchSample sample = random.batch();
  while (sample.reports._length < 2) sample = random.batch();
  const Bytes whole = topics.by_cyclone(&sample);
  for (std::size_t size = 0; size < whole.size(); ++size) {
    bool ok = true;
    std::string error;
    const std::vector<ReportView> views =
        views_of(Bytes(whole.begin(), whole.begin() + std::ptrdiff_t(size)), true, ok, error);
    ASSERT_FALSE(ok) << "a prefix of " << size << " of " << whole.size() << " bytes was accepted";
    ASSERT_FALSE(error.empty());
    ASSERT_LT(views.size(), sample.reports._length);
    for (std::size_t k = 0; k < views.size(); ++k)
      expect_view_of(views[k], sample.reports._buffer[k]);
  }
  Bytes big_endian = whole;
  big_endian[1] = 0x00;  // CDR_BE: Cyclone hands its readers host order only
  bool ok = true;
  std::string error;
  EXPECT_TRUE(views_of(big_endian, true, ok, error).empty());
  EXPECT_FALSE(ok);
  EXPECT_NE(error.find("XCDR1"), std::string::npos) << error;
}

// The fuzz target's seeds (tests/fuzz/make_seeds.py writes them with a CDR writer of its own, in
// Python): each one a report, or a batch of them, that the reader accepts whole.
TEST(DdsReportView, AcceptsTheFuzzSeedsWrittenByAnotherWriter) {
  const std::filesystem::path seeds =
      std::filesystem::path(NEARPOINT_SOURCE_DIR) / "tests/fuzz/corpus/dds_report_view";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(seeds)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const Bytes input((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GE(input.size(), 9u) << entry.path();
    const bool batch = input[0] & 1;
    bool ok = false;
    std::string error;
    const std::vector<ReportView> views =
        views_of(Bytes(input.begin() + 1, input.end()), batch, ok, error);
    EXPECT_TRUE(ok) << entry.path() << ": " << error;
    EXPECT_EQ(views.size(), batch ? std::size_t(input[5]) : 1u) << entry.path();
    for (const ReportView& view : views) EXPECT_EQ(view.server_us, 30.5) << entry.path();
    ++files;
  }
  EXPECT_GE(files, 5);
}

}  // namespace
