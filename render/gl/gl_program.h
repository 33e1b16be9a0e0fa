// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A shader program from GLSL source, for the renderer and its passes.

#include <string>

#include <epoxy/gl.h>

namespace cityatlas::render {

/// Compiles one shader; 0 with a one-line *error ("GL renderer: NAME shader
/// does not compile: ...") when it does not.
GLuint compileShader(GLenum type, const char* source, const char* name, std::string* error);
/// Compiles and links a vertex and a fragment shader; 0 with a one-line
/// *error when either does not compile or the program does not link.
GLuint linkProgram(const char* vertex_source, const char* fragment_source, std::string* error);

}  // namespace cityatlas::render
