// report.yaml / report.json, allan.csv and the printed summary, written atomically.
#include "gyro_allan/io/report.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace gyro_allan {
namespace {

/// A double as a plain YAML scalar with 10 significant digits (yaml-cpp would print 17: 0.68300000000000005).
YAML::Node num(double v) {
  if (std::isnan(v)) return YAML::Node(".nan");
  if (std::isinf(v)) return YAML::Node(v > 0 ? ".inf" : "-.inf");
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return YAML::Node(std::string(buf));
}

YAML::Node coefficientNode(const Coefficient& c, const char* unit) {
  YAML::Node n;
  n["value"] = num(c.value);
  n["sigma"] = num(c.sigma);
  n["supported"] = c.supported;
  n["unit"] = unit;
  return n;
}

YAML::Node coefficientsNode(const FitResult& fit) {
  YAML::Node n;
  for (int t = 0; t < kNumTerms; ++t) n[noiseTermKey(t)] = coefficientNode(fit.terms[static_cast<size_t>(t)], noiseTermUnit(t));
  return n;
}

YAML::Node fitNode(const FitResult& fit) {
  YAML::Node n;
  n["ok"] = fit.ok;
  if (!fit.ok) n["message"] = fit.message;
  n["rms_log10"] = num(fit.rms_log10);
  n["chi2_dof"] = num(fit.chi2_dof);
  n["dof"] = fit.dof;
  n["rms_points"] = fit.n_rms;
  return n;
}

void jsonString(std::ostringstream& o, const std::string& s) {
  o << '"';
  for (char ch : s) {
    switch (ch) {
      case '"': o << "\\\""; break;
      case '\\': o << "\\\\"; break;
      case '\n': o << "\\n"; break;
      case '\t': o << "\\t"; break;
      default:
        if (static_cast<unsigned char>(ch) < 0x20) o << "\\u" << std::hex << std::setw(4) << std::setfill('0') << int(ch) << std::dec;
        else o << ch;
    }
  }
  o << '"';
}

void jsonValue(std::ostringstream& o, const YAML::Node& n, int indent) {
  const std::string pad(static_cast<size_t>(indent) * 2, ' ');
  const std::string pad2(static_cast<size_t>(indent + 1) * 2, ' ');
  if (n.IsMap()) {
    o << "{";
    bool first = true;
    for (auto it = n.begin(); it != n.end(); ++it) {
      o << (first ? "\n" : ",\n") << pad2;
      first = false;
      jsonString(o, it->first.as<std::string>());
      o << ": ";
      jsonValue(o, it->second, indent + 1);
    }
    o << (first ? "}" : "\n" + pad + "}");
  } else if (n.IsSequence()) {
    o << "[";
    for (size_t i = 0; i < n.size(); ++i) {
      o << (i ? ", " : "");
      jsonValue(o, n[i], indent + 1);
    }
    o << "]";
  } else if (n.IsScalar()) {
    const std::string s = n.Scalar();
    if (s == "true" || s == "false") {
      o << s;
      return;
    }
    if (s == ".nan" || s == ".inf" || s == "-.inf") {
      o << "null";
      return;
    }
    char* end = nullptr;
    std::strtod(s.c_str(), &end);
    if (!s.empty() && end && *end == '\0' && n.Tag() != "!") o << s;
    else jsonString(o, s);
  } else {
    o << "null";
  }
}

std::string fmtCoef(const Coefficient& c, double factor) {
  char buf[64];
  if (!c.supported) std::snprintf(buf, sizeof buf, "0 (<%.3g)", c.sigma * factor);
  else std::snprintf(buf, sizeof buf, "%.4g +- %.2g", c.value * factor, c.sigma * factor);
  return buf;
}

}  // namespace

YAML::Node buildReport(const ReportMeta& meta, const std::vector<AxisAnalysis>& axes) {
  YAML::Node r;
  r["tool"] = "gyro_allan analyze_bag";
  r["version"] = "0.1.0";
  YAML::Node in;
  for (const auto& s : meta.sources) in["sources"].push_back(s);
  if (!meta.topic.empty()) in["topic"] = meta.topic;
  in["kind"] = meta.input;
  in["units"] = meta.input_units;
  r["input"] = in;
  r["method"] = "joint_fit";
  r["tau_grid"] = meta.tau_grid;
  r["confidence"] = num(meta.confidence);
  YAML::Node st;
  st["input"] = meta.stamps.input;
  st["kept"] = meta.stamps.kept;
  st["non_finite"] = meta.stamps.non_finite;
  st["zero_stamp"] = meta.stamps.zero_stamp;
  st["out_of_order"] = meta.stamps.out_of_order;
  st["duplicate"] = meta.stamps.duplicate;
  st["short_segment"] = meta.stamps.short_segment;
  st["gaps"] = meta.stamps.gaps;
  st["gap_time_s"] = num(meta.stamps.gap_time_s);
  st["rate_changed"] = meta.stamps.rate_changed;
  r["stamps"] = st;
  r["warnings"] = YAML::Node(YAML::NodeType::Sequence);
  for (const auto& w : meta.warnings) r["warnings"].push_back(w);
  YAML::Node ax;
  for (const auto& a : axes) {
    YAML::Node n;
    n["samples"] = a.samples;
    n["segments"] = a.segments;
    n["rate_hz"] = num(a.rate_hz);
    n["duration_s"] = num(a.duration_s);
    n["mean"] = num(a.mean);
    n["coefficients"] = coefficientsNode(a.fit);
    n["fit"] = fitNode(a.fit);
    YAML::Node jf;
    jf["coefficients"] = coefficientsNode(a.fit);
    jf["fit"] = fitNode(a.fit);
    n["methods"]["joint_fit"] = jf;
    ax[a.axis] = n;
  }
  r["axes"] = ax;
  return r;
}

std::string toYaml(const YAML::Node& node) {
  YAML::Emitter e;
  e.SetDoublePrecision(10);
  e << node;
  return std::string(e.c_str()) + "\n";
}

std::string toJson(const YAML::Node& node) {
  std::ostringstream o;
  jsonValue(o, node, 0);
  o << "\n";
  return o.str();
}

std::string allanCsv(const std::vector<AxisAnalysis>& axes) {
  std::ostringstream o;
  o << std::setprecision(10);
  o << "axis,deviation,tau_s,m,dev,dev_lo,dev_hi,edf,alpha,n_terms,model_dev\n";
  for (const auto& a : axes) {
    auto rows = [&](const DeviationCurve& c, bool with_model) {
      for (size_t i = 0; i < c.points.size(); ++i) {
        const auto& p = c.points[i];
        const double model = with_model ? std::sqrt(std::max(0.0, modelVariance(a.fit, p.tau))) : NAN;
        o << a.axis << ',' << c.name << ',' << p.tau << ',' << p.m << ',' << p.dev << ',' << p.dev_lo << ','
          << p.dev_hi << ',' << p.edf << ',' << p.alpha << ',' << p.n_terms << ',';
        if (with_model) o << model;
        o << '\n';
      }
    };
    bool wrote_oadev = false;
    for (const auto& c : a.curves) {
      rows(c, c.name == "oadev");
      wrote_oadev = wrote_oadev || c.name == "oadev";
    }
    if (!wrote_oadev) rows(a.oadev, true);
  }
  return o.str();
}

std::string summaryTable(const std::vector<AxisAnalysis>& axes) {
  std::ostringstream o;
  o << std::left << std::setw(6) << "axis";
  const char* short_names[] = {"Q", "N", "B", "K", "R"};
  for (int t = 0; t < kNumTerms; ++t)
    o << std::setw(24) << (std::string(short_names[t]) + " [" + conventionalUnit(t) + "]");
  o << std::setw(11) << "rms_log10" << "chi2/dof\n";
  for (const auto& a : axes) {
    o << std::setw(6) << a.axis;
    for (int t = 0; t < kNumTerms; ++t) o << std::setw(24) << fmtCoef(a.fit.terms[static_cast<size_t>(t)], conventionalFactor(t));
    char buf[64];
    std::snprintf(buf, sizeof buf, "%-11.4f%.3g", a.fit.rms_log10, a.fit.chi2_dof);
    o << buf << "\n";
  }
  o << "(value +- 1 sigma; 0 (<b): not supported by the data, b = 1-sigma upper bound)\n";
  return o.str();
}

void writeFileAtomic(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error("cannot write '" + tmp + "'");
    f << content;
    f.flush();
    if (!f) {
      std::remove(tmp.c_str());  // never leave a half-written .tmp behind
      throw std::runtime_error("cannot write '" + tmp + "' (disk full?)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot rename '" + tmp + "' to '" + path + "'");
  }
}

}  // namespace gyro_allan
