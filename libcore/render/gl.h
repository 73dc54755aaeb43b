/* The OpenGL 3.3 core entry points the renderer uses, loaded through OSMesaGetProcAddress into a
 * table owned by the renderer (no global function pointers, no libGL). */
#ifndef PF_RENDER_GL_H
#define PF_RENDER_GL_H

#include <GL/osmesa.h>
#include <GL/glext.h>

#include <pf/base.h>

/* X(return type, name without the gl prefix, parameter list) */
/* clang-format off */
#define PF_GL_FUNCTIONS(X)                                                                         \
    X(GLenum, GetError, (void))                                                                    \
    X(void, Viewport, (GLint x, GLint y, GLsizei w, GLsizei h))                                    \
    X(void, ClearColor, (GLfloat r, GLfloat g, GLfloat b, GLfloat a))                              \
    X(void, ClearDepth, (GLdouble d))                                                              \
    X(void, Clear, (GLbitfield mask))                                                              \
    X(void, Enable, (GLenum cap))                                                                  \
    X(void, Disable, (GLenum cap))                                                                 \
    X(void, DepthFunc, (GLenum func))                                                              \
    X(void, PolygonOffset, (GLfloat factor, GLfloat units))                                        \
    X(void, PixelStorei, (GLenum pname, GLint param))                                              \
    X(void, ReadPixels, (GLint x, GLint y, GLsizei w, GLsizei h, GLenum format, GLenum type,       \
                         void *pixels))                                                            \
    X(void, ReadBuffer, (GLenum mode))                                                             \
    X(void, DrawBuffer, (GLenum mode))                                                             \
    X(void, GenTextures, (GLsizei n, GLuint *textures))                                            \
    X(void, DeleteTextures, (GLsizei n, const GLuint *textures))                                   \
    X(void, BindTexture, (GLenum target, GLuint texture))                                          \
    X(void, ActiveTexture, (GLenum texture))                                                       \
    X(void, TexImage2D, (GLenum target, GLint level, GLint internalformat, GLsizei w, GLsizei h,   \
                         GLint border, GLenum format, GLenum type, const void *pixels))            \
    X(void, TexImage2DMultisample, (GLenum target, GLsizei samples, GLenum internalformat,         \
                                    GLsizei w, GLsizei h, GLboolean fixedsamplelocations))         \
    X(void, TexParameteri, (GLenum target, GLenum pname, GLint param))                             \
    X(void, TexParameterfv, (GLenum target, GLenum pname, const GLfloat *params))                  \
    X(void, GenFramebuffers, (GLsizei n, GLuint *ids))                                             \
    X(void, DeleteFramebuffers, (GLsizei n, const GLuint *ids))                                    \
    X(void, BindFramebuffer, (GLenum target, GLuint id))                                           \
    X(void, FramebufferTexture2D, (GLenum target, GLenum attachment, GLenum textarget,            \
                                   GLuint texture, GLint level))                                   \
    X(GLenum, CheckFramebufferStatus, (GLenum target))                                             \
    X(void, GenRenderbuffers, (GLsizei n, GLuint *ids))                                            \
    X(void, DeleteRenderbuffers, (GLsizei n, const GLuint *ids))                                   \
    X(void, BindRenderbuffer, (GLenum target, GLuint id))                                          \
    X(void, RenderbufferStorageMultisample, (GLenum target, GLsizei samples,                      \
                                             GLenum internalformat, GLsizei w, GLsizei h))         \
    X(void, FramebufferRenderbuffer, (GLenum target, GLenum attachment, GLenum rbtarget,          \
                                      GLuint rb))                                                  \
    X(GLuint, CreateShader, (GLenum type))                                                         \
    X(void, ShaderSource, (GLuint shader, GLsizei count, const GLchar *const *string,             \
                           const GLint *length))                                                   \
    X(void, CompileShader, (GLuint shader))                                                        \
    X(void, GetShaderiv, (GLuint shader, GLenum pname, GLint *params))                             \
    X(void, GetShaderInfoLog, (GLuint shader, GLsizei size, GLsizei *length, GLchar *log))         \
    X(void, DeleteShader, (GLuint shader))                                                         \
    X(GLuint, CreateProgram, (void))                                                               \
    X(void, AttachShader, (GLuint program, GLuint shader))                                         \
    X(void, BindAttribLocation, (GLuint program, GLuint index, const GLchar *name))                \
    X(void, LinkProgram, (GLuint program))                                                         \
    X(void, GetProgramiv, (GLuint program, GLenum pname, GLint *params))                           \
    X(void, GetProgramInfoLog, (GLuint program, GLsizei size, GLsizei *length, GLchar *log))       \
    X(void, DeleteProgram, (GLuint program))                                                       \
    X(void, UseProgram, (GLuint program))                                                          \
    X(GLint, GetUniformLocation, (GLuint program, const GLchar *name))                             \
    X(void, Uniform1i, (GLint location, GLint v))                                                  \
    X(void, Uniform1f, (GLint location, GLfloat v))                                                \
    X(void, Uniform2fv, (GLint location, GLsizei count, const GLfloat *v))                         \
    X(void, Uniform3fv, (GLint location, GLsizei count, const GLfloat *v))                         \
    X(void, UniformMatrix4fv, (GLint location, GLsizei count, GLboolean transpose,                \
                               const GLfloat *v))                                                  \
    X(void, GenVertexArrays, (GLsizei n, GLuint *ids))                                             \
    X(void, DeleteVertexArrays, (GLsizei n, const GLuint *ids))                                    \
    X(void, BindVertexArray, (GLuint id))                                                          \
    X(void, GenBuffers, (GLsizei n, GLuint *ids))                                                  \
    X(void, DeleteBuffers, (GLsizei n, const GLuint *ids))                                         \
    X(void, BindBuffer, (GLenum target, GLuint id))                                                \
    X(void, BufferData, (GLenum target, GLsizeiptr size, const void *data, GLenum usage))          \
    X(void, VertexAttribPointer, (GLuint index, GLint size, GLenum type, GLboolean normalized,    \
                                  GLsizei stride, const void *pointer))                            \
    X(void, EnableVertexAttribArray, (GLuint index))                                               \
    X(void, DrawElements, (GLenum mode, GLsizei count, GLenum type, const void *indices))          \
    X(void, DrawArrays, (GLenum mode, GLint first, GLsizei count))

/* clang-format on */
#define PF_GL_MEMBER(ret, name, params) ret(GLAPIENTRY *name) params;
typedef struct pf_gl {
    PF_GL_FUNCTIONS(PF_GL_MEMBER)
} pf_gl;
#undef PF_GL_MEMBER

/* Fills gl from the current OSMesa context; PF_ERR_UNSUPPORTED naming the first missing entry. */
pf_status pf_gl_load(pf_gl *gl, pf_error *err);

/* Compiles and links a program from vertex and fragment sources, each preceded by the
 * "#version 330 core" line and the text in defines ("#define WIRE 1\n..."), binding the attribute
 * names attribs[0 .. n_attribs) to locations 0, 1, ...; PF_ERR_UNSUPPORTED with the info log. */
pf_status pf_gl_program(const pf_gl *gl, const char *name, const char *defines, const char *vs,
                        const char *fs, const char *const *attribs, int n_attribs, GLuint *program,
                        pf_error *err);

/* PF_ERR_UNSUPPORTED naming the GL error and what was being done, or PF_OK. */
pf_status pf_gl_check(const pf_gl *gl, const char *doing, pf_error *err);

/* GLSL sources (shaders.c), without the #version line. The scene shaders need WIRE (0 or 1) and
 * TAPS (shadow taps, >= 1) defined, the ground shader TAPS. */
extern const char *const PF_GLSL_SCENE_VS; /* objects: position, normal, colour, wire tags */
extern const char *const PF_GLSL_SCENE_FS;
extern const char *const PF_GLSL_DEPTH_VS; /* shadow map: depth only */
extern const char *const PF_GLSL_DEPTH_FS;
extern const char *const PF_GLSL_GROUND_VS; /* the ground plane */
extern const char *const PF_GLSL_GROUND_FS;
extern const char *const PF_GLSL_RESOLVE_VS; /* full-screen: multisample average, sRGB encode */
extern const char *const PF_GLSL_RESOLVE_FS;

#endif
