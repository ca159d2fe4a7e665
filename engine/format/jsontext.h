// JSON text in and out of unilod: the one way every command turns a JSON value into text and
// text into a JSON value.
// - Out: strings from the outside world (file paths, a DEM's CRS WKT, a file's build info) may
//   hold bytes that are not UTF-8 (a path with the byte 0xFF is a valid Linux path). JSON text
//   must be UTF-8 and nlohmann::json's default dump() throws on such bytes, which used to abort
//   `build`, `info --json` and `export`. Here every invalid byte sequence becomes U+FFFD.
// - In: a parse error (or a number out of double's range, e.g. 1e999) becomes a message with the
//   parser's line and column instead of an exception or a vague "not a JSON object".
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace unilod {

// `j` as JSON text (indent < 0: one line); invalid UTF-8 in strings is replaced by U+FFFD.
inline std::string jsonText(const nlohmann::json& j, int indent = -1) {
    return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

// `s` with every byte sequence that is not UTF-8 replaced by U+FFFD (for strings handed to
// libraries that write JSON themselves, e.g. tinygltf's extras).
inline std::string validUtf8(const std::string& s) {
    return nlohmann::json::parse(jsonText(nlohmann::json(s))).get<std::string>();
}

// Parses `text`; false with `error` = what is wrong and where (no file name: the caller adds it).
inline bool parseJson(const std::string& text, nlohmann::json& out, std::string& error) {
    try {
        out = nlohmann::json::parse(text);
        return true;
    } catch (const nlohmann::json::exception& e) {
        // what() is "[json.exception.<kind>.<id>] <message>": keep the message.
        std::string message = e.what();
        const std::size_t close = message.find("] ");
        if (message.compare(0, 1, "[") == 0 && close != std::string::npos)
            message.erase(0, close + 2);
        error = "not valid JSON: " + message;
        return false;
    }
}

}  // namespace unilod
