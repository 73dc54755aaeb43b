/* OpenGL plumbing: entry points from OSMesa, shader programs, error reports. */
#include "gl.h"

#include <string.h>

/* Function pointers pass through void (*)(void), the type C compilers treat as the generic one. */
typedef void (*any_function)(void);

pf_status pf_gl_load(pf_gl *gl, pf_error *err)
{
#define PF_GL_LOAD(ret, name, params)                                                              \
    gl->name = (ret(GLAPIENTRY *) params)(any_function)OSMesaGetProcAddress("gl" #name);           \
    PF_CHECK(gl->name, err, PF_ERR_UNSUPPORTED, "OpenGL entry point gl%s is missing", #name);
    PF_GL_FUNCTIONS(PF_GL_LOAD)
#undef PF_GL_LOAD
    return PF_OK;
}

static const char *error_name(GLenum e)
{
    switch (e) {
    case GL_INVALID_ENUM:
        return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE:
        return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION:
        return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
        return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY:
        return "GL_OUT_OF_MEMORY";
    default:
        return "unknown GL error";
    }
}

pf_status pf_gl_check(const pf_gl *gl, const char *doing, pf_error *err)
{
    GLenum e = gl->GetError();
    PF_CHECK(e == GL_NO_ERROR, err, PF_ERR_UNSUPPORTED, "OpenGL: %s (0x%04x) while %s",
             error_name(e), (unsigned)e, doing);
    return PF_OK;
}

static pf_status compile(const pf_gl *gl, const char *name, GLenum type, const char *defines,
                         const char *src, GLuint *shader, pf_error *err)
{
    const char *parts[3] = {"#version 330 core\n", defines ? defines : "", src};
    *shader = gl->CreateShader(type);
    gl->ShaderSource(*shader, 3, parts, NULL);
    gl->CompileShader(*shader);
    GLint ok = 0;
    gl->GetShaderiv(*shader, GL_COMPILE_STATUS, &ok);
    if (ok)
        return PF_OK;
    char log[400] = "";
    gl->GetShaderInfoLog(*shader, (GLsizei)sizeof log, NULL, log);
    gl->DeleteShader(*shader);
    *shader = 0;
    for (char *c = log; *c; ++c)
        if (*c == '\n')
            *c = ' ';
    return pf_error_set(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__,
                        "OpenGL: %s %s shader does not compile: %s", name,
                        type == GL_VERTEX_SHADER ? "vertex" : "fragment", log);
}

pf_status pf_gl_program(const pf_gl *gl, const char *name, const char *defines, const char *vs,
                        const char *fs, const char *const *attribs, int n_attribs, GLuint *program,
                        pf_error *err)
{
    GLuint v = 0, f = 0;
    PF_TRY(compile(gl, name, GL_VERTEX_SHADER, defines, vs, &v, err));
    pf_status s = compile(gl, name, GL_FRAGMENT_SHADER, defines, fs, &f, err);
    if (s != PF_OK) {
        gl->DeleteShader(v);
        return s;
    }
    GLuint p = gl->CreateProgram();
    gl->AttachShader(p, v);
    gl->AttachShader(p, f);
    for (int i = 0; i < n_attribs; ++i)
        gl->BindAttribLocation(p, (GLuint)i, attribs[i]);
    gl->LinkProgram(p);
    gl->DeleteShader(v);
    gl->DeleteShader(f);
    GLint ok = 0;
    gl->GetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[400] = "";
        gl->GetProgramInfoLog(p, (GLsizei)sizeof log, NULL, log);
        gl->DeleteProgram(p);
        for (char *c = log; *c; ++c)
            if (*c == '\n')
                *c = ' ';
        return pf_error_set(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__,
                            "OpenGL: %s program does not link: %s", name, log);
    }
    *program = p;
    return PF_OK;
}
