#include "mpm/core/json_input.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace pfm {

namespace {
// JSON pointer escaping (RFC 6901): '~' -> "~0", '/' -> "~1".
std::string escape_pointer_token(std::string_view token) {
  std::string out;
  for (const char c : token) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

const char* type_name(const nlohmann::json& v) {
  return v.type_name();
}
}  // namespace

namespace {

// Parses `text`, refusing an object that names a key twice (nlohmann keeps the last silently): the
// objects and arrays open at each point of the parse, with the keys seen and the current key or
// index, give the JSON pointer of the duplicate.
nlohmann::json parse_refusing_duplicate_keys(const std::string& text, const std::string& path) {
  struct Frame {
    bool array = false;
    std::set<std::string> keys;
    std::string key;
    long index = -1;
  };
  std::vector<Frame> frames;
  const auto element = [&] {
    if (!frames.empty() && frames.back().array) ++frames.back().index;
  };
  using Event = nlohmann::json::parse_event_t;
  const nlohmann::json::parser_callback_t callback = [&](int, Event event, nlohmann::json& parsed) {
    switch (event) {
      case Event::object_start:
      case Event::array_start:
        element();
        frames.push_back({});
        frames.back().array = event == Event::array_start;
        break;
      case Event::object_end:
      case Event::array_end:
        frames.pop_back();
        break;
      case Event::key: {
        Frame& f = frames.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second) {
          std::string pointer;
          for (const Frame& g : frames) {
            pointer.push_back('/');
            pointer.append(g.array ? std::to_string(g.index) : escape_pointer_token(g.key));
          }
          throw InputError(path + ": " + pointer + ": duplicate key (an object names it twice)");
        }
        break;
      }
      case Event::value:
        element();
        break;
    }
    return true;
  };
  return nlohmann::json::parse(text, callback);
}

}  // namespace

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file");
  // Read up to the limit only: a device that never ends (/dev/zero) or a huge file is refused
  // before it fills the memory.
  constexpr std::size_t kMaxBytes = std::size_t{64} << 20;
  std::string text;
  char chunk[1 << 16];
  while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
    text.append(chunk, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxBytes) {
      throw InputError(path + ": larger than " + std::to_string(kMaxBytes >> 20) +
                       " MB, not a case or configuration file");
    }
  }
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    throw InputError(path + ": file is empty, expected a JSON object");
  }
  // Copying, comparing or printing a JSON value recurses once per level of nesting: refuse
  // documents nested deeper than any input needs before they can exhaust the stack.
  constexpr int kMaxDepth = 256;
  int depth = 0, line = 1;
  bool in_string = false, escaped = false;
  for (const char ch : text) {
    if (ch == '\n') ++line;
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (ch == '\\') {
        escaped = true;
      } else if (ch == '"') {
        in_string = false;
      }
    } else if (ch == '"') {
      in_string = true;
    } else if (ch == '[' || ch == '{') {
      if (++depth > kMaxDepth) {
        throw InputError(path + ": line " + std::to_string(line) + ": JSON nested deeper than " +
                         std::to_string(kMaxDepth) + " levels");
      }
    } else if (ch == ']' || ch == '}') {
      --depth;
    }
  }
  try {
    return parse_refusing_duplicate_keys(text, path);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path + ": invalid JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  } catch (const nlohmann::json::exception& e) {
    // A number too large for a double (1e999): JSON has no inf or NaN. nlohmann gives no
    // position; the message quotes the number, so find its line.
    const std::string what = e.what();
    const auto open = what.find('\''), close = what.rfind('\'');
    std::string where;
    if (open != std::string::npos && close > open + 1) {
      const auto at = text.find(what.substr(open + 1, close - open - 1));
      if (at != std::string::npos) {
        where = " at line " + std::to_string(1 + std::count(text.begin(), text.begin() + at, '\n'));
      }
    }
    throw InputError(path + ": invalid JSON value" + where + ": " + what);
  }
}

JsonView::JsonView(const nlohmann::json& value, std::string file, std::string pointer)
    : value_(&value), file_(std::move(file)), pointer_(std::move(pointer)) {}

void JsonView::fail(const std::string& message) const {
  throw InputError(file_ + ": " + (pointer_.empty() ? std::string("/") : pointer_) + ": " +
                   message);
}

void JsonView::expect_object(std::initializer_list<std::string_view> allowed) const {
  if (!value_->is_object()) fail(std::string("expected an object, got ") + type_name(*value_));
  for (const auto& item : value_->items()) {
    bool known = false;
    for (const auto key : allowed) known = known || key == item.key();
    if (!known) {
      std::string list;
      for (const auto key : allowed) list += (list.empty() ? "" : ", ") + std::string(key);
      JsonView(item.value(), file_, pointer_ + "/" + escape_pointer_token(item.key()))
          .fail("unknown key (allowed here: " + list + ")");
    }
  }
}

bool JsonView::has(std::string_view key) const {
  return value_->is_object() && value_->contains(key);
}

JsonView JsonView::at(std::string_view key) const {
  if (!value_->is_object()) fail(std::string("expected an object, got ") + type_name(*value_));
  const auto it = value_->find(key);
  if (it == value_->end()) fail("missing key \"" + std::string(key) + "\"");
  return JsonView(*it, file_, pointer_ + "/" + escape_pointer_token(key));
}

std::optional<JsonView> JsonView::find(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  return at(key);
}

std::size_t JsonView::array_size() const {
  if (!value_->is_array()) fail(std::string("expected an array, got ") + type_name(*value_));
  return value_->size();
}

JsonView JsonView::at(std::size_t index) const {
  if (index >= array_size()) fail("index " + std::to_string(index) + " out of range");
  return JsonView((*value_)[index], file_, pointer_ + "/" + std::to_string(index));
}

double JsonView::as_number() const {
  if (!value_->is_number()) fail(std::string("expected a number, got ") + type_name(*value_));
  const double v = value_->get<double>();
  if (!std::isfinite(v)) fail("expected a finite number");
  return v;
}

int JsonView::as_int() const {
  if (!value_->is_number_integer()) {
    if (value_->is_number_float()) {
      const double v = value_->get<double>();
      if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 2e9) return static_cast<int>(v);
    }
    fail(std::string("expected a whole number, got ") + value_->dump());
  }
  if (value_->is_number_unsigned()) {
    const auto v = value_->get<std::uint64_t>();
    if (v > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) fail("number too large");
    return static_cast<int>(v);
  }
  const auto v = value_->get<std::int64_t>();
  if (v > std::numeric_limits<int>::max() || v < std::numeric_limits<int>::min()) {
    fail("number out of range");
  }
  return static_cast<int>(v);
}

bool JsonView::as_bool() const {
  if (!value_->is_boolean()) fail(std::string("expected true or false, got ") + type_name(*value_));
  return value_->get<bool>();
}

std::string JsonView::as_string() const {
  if (!value_->is_string()) fail(std::string("expected a string, got ") + type_name(*value_));
  return value_->get<std::string>();
}

std::string JsonView::as_choice(std::initializer_list<std::string_view> choices) const {
  const std::string v = as_string();
  std::string list;
  for (const auto c : choices) {
    if (c == v) return v;
    list += (list.empty() ? "\"" : ", \"") + std::string(c) + "\"";
  }
  fail("\"" + v + "\" is not one of " + list);
}

Vec2 JsonView::as_vec2() const {
  if (!value_->is_array() || value_->size() != 2) fail("expected [x, y]");
  return Vec2(at(std::size_t{0}).as_number(), at(std::size_t{1}).as_number());
}

double JsonView::number_or(std::string_view key, double fallback) const {
  return has(key) ? at(key).as_number() : fallback;
}

int JsonView::int_or(std::string_view key, int fallback) const {
  return has(key) ? at(key).as_int() : fallback;
}

std::string JsonView::choice_or(std::string_view key,
                                std::initializer_list<std::string_view> choices,
                                std::string_view fallback) const {
  return has(key) ? at(key).as_choice(choices) : std::string(fallback);
}

}  // namespace pfm
