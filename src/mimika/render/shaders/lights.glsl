// Studio lights in view space (set from a Lighting by mimika.render.skin.set_lights).
uniform vec3 u_key_dir;
uniform vec3 u_key_col;
uniform vec3 u_fill_dir;
uniform vec3 u_fill_col;
uniform vec3 u_rim_dir;
uniform vec3 u_rim_col;
uniform vec3 u_sky;
uniform vec3 u_ground;
