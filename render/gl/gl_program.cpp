// SPDX-License-Identifier: GPL-3.0-or-later
// Shader programs from GLSL source (render/gl/gl_program.h).
#include "render/gl/gl_program.h"

#include <algorithm>

#include <fmt/format.h>

namespace cityatlas::render {

namespace {

// The first line of a shader's or a program's info log (get_iv, get_log:
// glGetShaderiv and glGetShaderInfoLog, or the program ones).
template <class GetIv, class GetLog>
std::string firstLogLine(GLuint object, GetIv get_iv, GetLog get_log) {
    GLint length = 0;
    get_iv(object, GL_INFO_LOG_LENGTH, &length);
    std::string log(static_cast<size_t>(std::max(length, 1)), '\0');
    get_log(object, length, nullptr, log.data());
    std::string line = log.c_str();  // up to the log's terminating NUL
    line = line.substr(0, line.find('\n'));
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    return line.empty() ? "(no message)" : line;
}

}  // namespace

GLuint compileShader(GLenum type, const char* source, const char* name, std::string* error) {
    const GLuint shader = glCreateShader(type);
    glShaderSource(shader, 1, &source, nullptr);
    glCompileShader(shader);
    GLint ok = GL_FALSE;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
        *error = fmt::format("GL renderer: {} shader does not compile: {}", name,
                             firstLogLine(shader, glGetShaderiv, glGetShaderInfoLog));
        glDeleteShader(shader);
        return 0;
    }
    return shader;
}

GLuint linkProgram(const char* vertex_source, const char* fragment_source, std::string* error) {
    const GLuint vs = compileShader(GL_VERTEX_SHADER, vertex_source, "vertex", error);
    if (vs == 0) return 0;
    const GLuint fs = compileShader(GL_FRAGMENT_SHADER, fragment_source, "fragment", error);
    if (fs == 0) {
        glDeleteShader(vs);
        return 0;
    }
    const GLuint program = glCreateProgram();
    glAttachShader(program, vs);
    glAttachShader(program, fs);
    glLinkProgram(program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = GL_FALSE;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
        *error = fmt::format("GL renderer: shader program does not link: {}",
                             firstLogLine(program, glGetProgramiv, glGetProgramInfoLog));
        glDeleteProgram(program);
        return 0;
    }
    return program;
}

}  // namespace cityatlas::render
