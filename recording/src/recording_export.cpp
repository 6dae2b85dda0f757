// hexa_recorder export: one CSV file per topic, every protobuf field a column with its unit,
// and a README.txt.

#include "hexa/recording/recording.hpp"

#include <fnmatch.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "hexa/recording/csv_columns.hpp"

namespace hexa::recorder {
namespace gp = google::protobuf;

bool TopicFilter::NamesExplicitly(const std::string& topic) const {
  return std::find(include.begin(), include.end(), topic) != include.end();
}

bool TopicFilter::Matches(const std::string& topic) const {
  auto any = [&](const std::vector<std::string>& globs) {
    for (const auto& g : globs)
      if (fnmatch(g.c_str(), topic.c_str(), 0) == 0) return true;
    return false;
  };
  if (!include.empty() && !any(include)) return false;
  return !any(exclude);
}

namespace {
void CsvField(std::string& out, const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) {
    out += s;
    return;
  }
  out += '"';
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
}

std::string ScalarText(const gp::Message& m, const gp::FieldDescriptor* f, int index) {
  const gp::Reflection* r = m.GetReflection();
  const bool rep = f->is_repeated();
  char buf[64];
  switch (f->cpp_type()) {
    case gp::FieldDescriptor::CPPTYPE_DOUBLE:
      std::snprintf(buf, sizeof buf, "%.17g", rep ? r->GetRepeatedDouble(m, f, index) : r->GetDouble(m, f));
      return buf;
    case gp::FieldDescriptor::CPPTYPE_FLOAT:
      std::snprintf(buf, sizeof buf, "%.9g", rep ? r->GetRepeatedFloat(m, f, index) : r->GetFloat(m, f));
      return buf;
    case gp::FieldDescriptor::CPPTYPE_INT32:
      return std::to_string(rep ? r->GetRepeatedInt32(m, f, index) : r->GetInt32(m, f));
    case gp::FieldDescriptor::CPPTYPE_INT64:
      return std::to_string(rep ? r->GetRepeatedInt64(m, f, index) : r->GetInt64(m, f));
    case gp::FieldDescriptor::CPPTYPE_UINT32:
      return std::to_string(rep ? r->GetRepeatedUInt32(m, f, index) : r->GetUInt32(m, f));
    case gp::FieldDescriptor::CPPTYPE_UINT64:
      return std::to_string(rep ? r->GetRepeatedUInt64(m, f, index) : r->GetUInt64(m, f));
    case gp::FieldDescriptor::CPPTYPE_BOOL:
      return (rep ? r->GetRepeatedBool(m, f, index) : r->GetBool(m, f)) ? "1" : "0";
    case gp::FieldDescriptor::CPPTYPE_ENUM:
      return (rep ? r->GetRepeatedEnum(m, f, index) : r->GetEnum(m, f))->name();
    case gp::FieldDescriptor::CPPTYPE_STRING:
      return rep ? r->GetRepeatedString(m, f, index) : r->GetString(m, f);
    default:
      return "";
  }
}

// Column layout of one channel: fixed by the first message (repeated-field sizes included).
struct Column {
  std::vector<const gp::FieldDescriptor*> path;  // nested singular messages, then the leaf
  int index = -1;                                // element of a repeated leaf
  std::string name;
};

void BuildColumns(const gp::Message& m, std::vector<const gp::FieldDescriptor*> path,
                  const std::string& prefix, std::vector<Column>& out) {
  const gp::Descriptor* d = m.GetDescriptor();
  const gp::Reflection* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const gp::FieldDescriptor* f = d->field(i);
    auto p = path;
    p.push_back(f);
    const std::string name = prefix + f->name();
    if (f->cpp_type() == gp::FieldDescriptor::CPPTYPE_MESSAGE) {
      if (!f->is_repeated()) BuildColumns(r->GetMessage(m, f), p, name + ".", out);
      continue;  // repeated messages have no flat CSV form
    }
    if (f->is_repeated()) {
      for (int k = 0; k < r->FieldSize(m, f); ++k)
        out.push_back({p, k, prefix + ElementName(*f, k) + " [" + ColumnUnit(*f, k) + "]"});
    } else {
      out.push_back({p, -1, name + " [" + ColumnUnit(*f, -1) + "]"});
    }
  }
}

struct ExportedFile {
  std::string file, topic, type;
  uint64_t rows;
  std::vector<std::string> columns;
};

// README.txt beside the CSVs: what each file holds and how its header reads.
void WriteExportReadme(const std::string& readme, const std::string& recording,
                       const std::vector<ExportedFile>& files) {
  std::ofstream o(readme);
  if (!o) throw McapError("cannot write '" + readme + "': " + std::strerror(errno));
  o << "CSV export of " << recording << " (hexa_recorder export; docs/recorder.md, \"CLI\").\n\n"
    << "One file per topic, one row per recorded message. Every header cell is \"name [unit]\":\n"
    << "SI units (m, rad, s, ns, Pa, V, N, kg, Hz and their products), [1] for a dimensionless\n"
    << "number (counts, ids, tick numbers of 1 ms, flags 0/1, quaternion components, scale\n"
    << "factors), [-] for text (strings, enum names). Nested fields read a.b; repeated fields\n"
    << "name the component they hold (desired_pose.x, orientation_wxyz.w, leg_length_m.leg3)\n"
    << "or their index (name[i]). log_time_ns: when the recorder received the message;\n"
    << "publish_time_ns: the writer's source time (both CLOCK_REALTIME); header.tick and\n"
    << "header.sim_time_s: the simulated time the sample belongs to. The Foxglove 3-D scene\n"
    << "(hexa_Scene, hexa_FrameTransforms) has no flat form and is exported only when --topics\n"
    << "names it.\n\n";
  for (const auto& f : files) {
    o << f.file << ": topic " << f.topic << ", message " << f.type << ", " << f.rows << " rows\n";
    const std::string what = MessageDescription(f.type);
    if (!what.empty()) o << "  " << what << "\n";
    o << "  columns: log_time_ns [ns], publish_time_ns [ns], sequence [1]";
    for (const auto& c : f.columns) o << ", " << c;
    o << "\n\n";
  }
  if (!o) throw McapError("writing '" + readme + "' failed");
}

std::string ColumnValue(const gp::Message& root, const Column& c) {
  const gp::Message* m = &root;
  for (size_t i = 0; i + 1 < c.path.size(); ++i) m = &m->GetReflection()->GetMessage(*m, c.path[i]);
  const gp::FieldDescriptor* leaf = c.path.back();
  if (c.index >= 0 && c.index >= m->GetReflection()->FieldSize(*m, leaf)) return "";
  return ScalarText(*m, leaf, c.index);
}
}  // namespace

ExportResult ExportCsv(const std::string& path, const std::string& out_dir,
                       const TopicFilter& filter) {
  struct stat st {};
  if (::stat(out_dir.c_str(), &st) != 0 && ::mkdir(out_dir.c_str(), 0755) != 0)
    throw McapError("cannot create output directory '" + out_dir + "': " + std::strerror(errno));
  struct Sink {
    std::ofstream file;
    std::string path;       // final name
    std::string temp_path;  // written here, renamed to `path` once the whole export succeeded
    std::vector<Column> columns;
    uint64_t rows = 0;
    std::string type, topic;
  };
  std::map<uint16_t, Sink> sinks;
  // All or nothing: CSVs are written under temporary names and renamed only after the whole
  // recording was read and every file closed without error; on any error the temporary files
  // are removed, so an export that fails leaves no partial CSV behind (and no older CSV of the
  // same name is touched).
  struct RemoveTemps {
    std::map<uint16_t, Sink>& sinks;
    bool armed = true;
    ~RemoveTemps() {
      if (!armed) return;
      for (auto& [id, s] : sinks) {
        s.file.close();
        std::remove(s.temp_path.c_str());
      }
    }
  } guard{sinks};
  std::string row;
  const McapScanResult scan = ReadRecording(path, [&](const McapChannel& ch, const McapMessageView& m, const gp::Message& msg) {
    if (!filter.Matches(ch.topic)) return;
    // The 3-D scene is a drawing (repeated messages, no flat form): exported only by name.
    if (msg.GetDescriptor()->file()->package() == "foxglove" && !filter.NamesExplicitly(ch.topic))
      return;
    auto it = sinks.find(ch.id);
    if (it == sinks.end()) {
      std::string name = ch.topic;
      std::replace_if(name.begin(), name.end(), [](char c) { return !std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-'; }, '_');
      name.erase(0, name.find_first_not_of('_'));
      if (name.size() > 100) name.resize(100);  // a file name, not the whole topic string
      Sink s;
      s.path = out_dir + "/" + (name.empty() ? "channel" + std::to_string(ch.id) : name) + ".csv";
      s.temp_path = s.path + ".partial." + std::to_string(::getpid());
      it = sinks.emplace(ch.id, std::move(s)).first;
      Sink& n = it->second;
      n.file.open(n.temp_path, std::ios::out | std::ios::trunc);
      if (!n.file) throw McapError("cannot write '" + n.temp_path + "': " + std::strerror(errno));
      BuildColumns(msg, {}, "", n.columns);
      n.file << "log_time_ns [ns],publish_time_ns [ns],sequence [1]";
      n.type = msg.GetDescriptor()->full_name();
      n.topic = ch.topic;
      for (const auto& c : n.columns) n.file << ',' << c.name;
      n.file << '\n';
    }
    Sink& s = it->second;
    row = std::to_string(m.log_time_ns) + ',' + std::to_string(m.publish_time_ns) + ',' +
          std::to_string(m.sequence);
    for (const auto& c : s.columns) {
      row += ',';
      CsvField(row, ColumnValue(msg, c));
    }
    row += '\n';
    s.file << row;
    if (!s.file) throw McapError("writing '" + s.temp_path + "' failed: " + std::strerror(errno));
    ++s.rows;
  });
  ExportResult result;
  for (auto& [id, s] : sinks) {
    s.file.close();
    if (!s.file) throw McapError("writing '" + s.temp_path + "' failed");
  }
  for (auto& [id, s] : sinks) {
    if (std::rename(s.temp_path.c_str(), s.path.c_str()) != 0)
      throw McapError("cannot rename '" + s.temp_path + "' to '" + s.path + "': " + std::strerror(errno));
    result.files.emplace_back(s.path, s.rows);
  }
  guard.armed = false;
  result.warnings = scan.problems;
  std::vector<ExportedFile> described;
  for (const auto& [id, s] : sinks) {
    ExportedFile e{s.path.substr(out_dir.size() + 1), s.topic, s.type, s.rows, {}};
    for (const auto& c : s.columns) e.columns.push_back(c.name);
    described.push_back(std::move(e));
  }
  WriteExportReadme(out_dir + "/README.txt", path, described);
  return result;
}

}  // namespace hexa::recorder
