// A ROS 2 recording as a list of storage files: a rosbag2 folder (metadata.yaml, rosbag2_storage's yaml.hpp
// versions 1-9) or files given alone, with rosbag2's zstd FILE and MESSAGE compression undone.
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include <yaml-cpp/yaml.h>
#include <zstd.h>

#include "gyro_allan/rosbag2/storage.hpp"

namespace gyro_allan {
namespace rosbag2 {
namespace {

const char kMcapMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};
const char kSqliteMagic[16] = {'S', 'Q', 'L', 'i', 't', 'e', ' ', 'f', 'o', 'r', 'm', 'a', 't', ' ', '3', '\0'};
const char kZstdMagic[4] = {'\x28', '\xb5', '\x2f', '\xfd'};

bool isDir(const std::string& p) {
  struct stat st {};
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}
bool isFile(const std::string& p) {
  struct stat st {};
  return stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}
bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}
std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}
/// The first bytes of a file ("" when unreadable).
std::string head(const std::string& path, size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string b(n, '\0');
  f.read(&b[0], static_cast<std::streamsize>(n));
  b.resize(static_cast<size_t>(f.gcount()));
  return b;
}
bool isStorageName(const std::string& name) {
  return endsWith(name, ".mcap") || endsWith(name, ".db3") || endsWith(name, ".mcap.zstd") ||
         endsWith(name, ".db3.zstd");
}
/// Files of a folder whose names are storage files, sorted by name.
std::vector<std::string> storageFilesIn(const std::string& dir) {
  std::vector<std::string> out;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name;
      if (isStorageName(n) && isFile(dir + "/" + n)) out.push_back(dir + "/" + n);
    }
    closedir(d);
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// Decompresses a zstd file (rosbag2 FILE compression) into a new temporary file; returns its path.
std::string decompressFile(const std::string& path) {
  const char* tmp = std::getenv("TMPDIR");
  std::string name = std::string(tmp && *tmp ? tmp : "/tmp") + "/gyro_allan_XXXXXX";
  std::vector<char> tmpl(name.begin(), name.end());
  tmpl.push_back('\0');
  const int fd = mkstemp(tmpl.data());
  if (fd < 0) throw FormatError(path + ": cannot make a temporary file to decompress it into");
  const std::string out_path(tmpl.data());
  FILE* out = fdopen(fd, "wb");
  std::ifstream in(path, std::ios::binary);
  ZSTD_DCtx* ctx = ZSTD_createDCtx();
  auto fail = [&](const std::string& why) {
    ZSTD_freeDCtx(ctx);
    if (out) std::fclose(out);
    std::remove(out_path.c_str());
    throw FormatError(path + ": " + why);
  };
  if (!in || !out || !ctx) fail("cannot read or decompress it");
  std::vector<char> ib(ZSTD_DStreamInSize()), ob(ZSTD_DStreamOutSize());
  size_t last = 0;
  bool any = false;
  while (in) {
    in.read(ib.data(), static_cast<std::streamsize>(ib.size()));
    const size_t n = static_cast<size_t>(in.gcount());
    if (n == 0) break;
    any = true;
    ZSTD_inBuffer zin{ib.data(), n, 0};
    while (zin.pos < zin.size) {
      ZSTD_outBuffer zout{ob.data(), ob.size(), 0};
      last = ZSTD_decompressStream(ctx, &zout, &zin);
      if (ZSTD_isError(last)) fail(std::string("not a zstd file (") + ZSTD_getErrorName(last) + ")");
      if (std::fwrite(ob.data(), 1, zout.pos, out) != zout.pos) fail("cannot write its decompressed copy");
    }
  }
  if (!any || last != 0) fail("truncated zstd file");
  ZSTD_freeDCtx(ctx);
  if (std::fclose(out) != 0) {
    std::remove(out_path.c_str());
    throw FormatError(path + ": cannot write its decompressed copy");
  }
  return out_path;
}

}  // namespace

std::unique_ptr<Storage> openStorage(const std::string& path) {
  if (!isFile(path)) throw FormatError("cannot open '" + path + "': no such file or not readable");
  const std::string h = head(path, 16);
  if (h.size() >= 8 && std::memcmp(h.data(), kMcapMagic, 8) == 0) return openMcap(path);
  if (h.size() >= 16 && std::memcmp(h.data(), kSqliteMagic, 16) == 0) return openSqlite3(path);
  if (h.empty()) throw FormatError(path + ": empty file");
  if (endsWith(path, ".mcap")) throw FormatError(path + ": not an MCAP file (no MCAP magic at its start)");
  if (endsWith(path, ".db3")) throw FormatError(path + ": not a sqlite3 file (no SQLite magic at its start)");
  throw FormatError(path + ": neither MCAP nor sqlite3 (no MCAP or SQLite magic at its start)");
}

bool isRos2Input(const std::string& path) {
  if (isDir(path)) return isFile(path + "/metadata.yaml") || !storageFilesIn(path).empty();
  if (isStorageName(path)) return true;
  const std::string h = head(path, 16);
  return (h.size() >= 8 && std::memcmp(h.data(), kMcapMagic, 8) == 0) ||
         (h.size() >= 16 && std::memcmp(h.data(), kSqliteMagic, 16) == 0);
}

Bag::Bag(const std::vector<std::string>& paths) {
  struct Entry {
    std::string file;   // as given / named by metadata.yaml
    bool from_metadata;
  };
  std::vector<Entry> entries;
  bool any_metadata = false;
  for (const auto& p : paths) {
    if (isDir(p)) {
      const std::string meta = p + "/metadata.yaml";
      if (isFile(meta)) {
        YAML::Node info;
        try {
          info = YAML::LoadFile(meta)["rosbag2_bagfile_information"];
        } catch (const std::exception& e) {
          throw FormatError(meta + ": not readable YAML (" + std::string(e.what()) + ")");
        }
        if (!info || !info.IsMap()) throw FormatError(meta + ": no rosbag2_bagfile_information");
        try {
          metadata_version_ = info["version"] ? info["version"].as<int>() : 0;
          if (info["compression_format"]) compression_format_ = info["compression_format"].as<std::string>();
          if (info["compression_mode"]) compression_mode_ = lower(info["compression_mode"].as<std::string>());
          const std::string storage = info["storage_identifier"] ? info["storage_identifier"].as<std::string>() : "";
          if (!storage.empty() && storage != "sqlite3" && storage != "mcap")
            throw FormatError(meta + ": storage '" + storage + "' is not supported (sqlite3 or mcap)");
          const YAML::Node files = info["relative_file_paths"];
          if (!files || !files.IsSequence() || files.size() == 0)
            throw FormatError(meta + ": no relative_file_paths");
          for (const auto& f : files) {
            const std::string rel = f.as<std::string>();
            // rosbag2 wrote folder-prefixed paths in early versions ("bag/bag_0.db3"): take the file name then.
            std::string file = p + "/" + rel;
            if (!isFile(file)) {
              const size_t slash = rel.find_last_of('/');
              if (slash != std::string::npos && isFile(p + "/" + rel.substr(slash + 1))) file = p + "/" + rel.substr(slash + 1);
            }
            entries.push_back({file, true});
          }
        } catch (const YAML::Exception& e) {
          throw FormatError(meta + ": unexpected content (" + std::string(e.what()) + ")");
        }
        if (!compression_mode_.empty() && compression_mode_ != "none") {
          if (compression_format_ != "zstd")
            throw FormatError(meta + ": compression '" + compression_format_ + "' is not supported (zstd)");
          if (compression_mode_ != "file" && compression_mode_ != "message")
            throw FormatError(meta + ": compression mode '" + compression_mode_ + "' is not supported (FILE, MESSAGE)");
        }
        any_metadata = true;
      } else {
        const auto files = storageFilesIn(p);
        if (files.empty()) throw FormatError("'" + p + "': no metadata.yaml and no .mcap or .db3 file in the folder");
        for (const auto& f : files) entries.push_back({f, false});
      }
    } else {
      entries.push_back({p, false});
    }
  }
  if (any_metadata && paths.size() > 1)
    throw FormatError("give one rosbag2 folder (its metadata.yaml lists its files), or storage files alone");
  for (const auto& e : entries) {
    if (!isFile(e.file)) throw FormatError("cannot open '" + e.file + "': no such file or not readable");
    std::string open_path = e.file;
    const bool zst = head(e.file, 4) == std::string(kZstdMagic, 4);
    if (zst || endsWith(e.file, ".zstd")) {
      if (!zst) throw FormatError(e.file + ": named .zstd but not a zstd file");
      open_path = decompressFile(e.file);
      temporaries_.push_back(open_path);
    }
    try {
      storages_.push_back(openStorage(open_path));
    } catch (const FormatError& err) {
      std::string what = err.what();
      if (open_path != e.file) {  // name the file the user has, not the temporary copy
        const size_t at = what.find(open_path);
        if (at != std::string::npos) what.replace(at, open_path.size(), e.file + " (decompressed)");
      }
      throw FormatError(what);
    }
    files_.push_back(e.file);
  }
  if (!any_metadata && storages_.size() > 1) {
    // Files without metadata: in order of their first message, as several ROS 1 bags are.
    std::vector<size_t> order(storages_.size());
    std::vector<int64_t> start(storages_.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i, start[i] = storages_[i]->startNs();
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return start[a] < start[b]; });
    std::vector<std::unique_ptr<Storage>> s;
    std::vector<std::string> f;
    for (size_t i : order) s.push_back(std::move(storages_[i])), f.push_back(files_[i]);
    storages_ = std::move(s);
    files_ = std::move(f);
  }
  for (size_t i = 0; i < storages_.size(); ++i)
    for (const auto& t : storages_[i]->topics()) {
      const auto it = types_.find(t.name);
      if (it == types_.end())
        types_[t.name] = t.type, formats_[t.name] = t.serialization_format;
      else if (it->second != t.type)
        throw FormatError(files_[i] + ": topic " + t.name + " has type " + t.type + " here, " + it->second +
                          " in an earlier file");
    }
}

Bag::~Bag() {
  storages_.clear();
  for (const auto& t : temporaries_) std::remove(t.c_str());
}

std::map<std::string, int64_t> Bag::messageCounts() {
  std::map<std::string, int64_t> out;
  for (auto& s : storages_) {
    const auto c = s->messageCounts();
    for (size_t i = 0; i < c.size(); ++i) out[s->topics()[i].name] += c[i];
  }
  return out;
}

std::vector<std::string> Bag::describe() const {
  std::vector<std::string> out;
  for (size_t i = 0; i < storages_.size(); ++i) out.push_back(files_[i] + ": " + storages_[i]->describe());
  if (metadata_version_ > 0 || !compression_mode_.empty()) {
    std::string m = "metadata.yaml version " + std::to_string(metadata_version_);
    if (!compression_mode_.empty() && compression_mode_ != "none")
      m += ", " + compression_format_ + " " + compression_mode_ + " compression";
    out.push_back(m);
  }
  return out;
}

void Bag::read(const std::set<std::string>& topics,
               const std::function<void(const std::string&, int64_t, const uint8_t*, size_t)>& f) {
  const bool per_message = compression_mode_ == "message";
  ZSTD_DCtx* ctx = per_message ? ZSTD_createDCtx() : nullptr;
  std::vector<uint8_t> plain;
  try {
    for (size_t i = 0; i < storages_.size(); ++i) {
      Storage& s = *storages_[i];
      std::vector<bool> wanted(s.topics().size());
      for (size_t k = 0; k < wanted.size(); ++k) wanted[k] = topics.count(s.topics()[k].name) > 0;
      s.read(wanted, [&](const StoredMessage& m) {
        const std::string& name = s.topics()[m.topic].name;
        if (!per_message) {
          f(name, m.recv_ns, m.data, m.size);
          return;
        }
        const unsigned long long n = ZSTD_getFrameContentSize(m.data, m.size);
        if (n == ZSTD_CONTENTSIZE_ERROR || n == ZSTD_CONTENTSIZE_UNKNOWN || n > (64u << 20))
          throw FormatError(files_[i] + ": a message on " + name + " is not a zstd frame (MESSAGE compression)");
        plain.resize(static_cast<size_t>(n));
        const size_t got = ZSTD_decompressDCtx(ctx, plain.data(), plain.size(), m.data, m.size);
        if (ZSTD_isError(got) || got != n)
          throw FormatError(files_[i] + ": a message on " + name + " does not decompress (MESSAGE compression)");
        f(name, m.recv_ns, plain.data(), plain.size());
      });
    }
  } catch (...) {
    ZSTD_freeDCtx(ctx);
    throw;
  }
  ZSTD_freeDCtx(ctx);
}

}  // namespace rosbag2
}  // namespace gyro_allan
