// 3D trunk preview: the result's material set on a displaced cylinder.
//
// This module imports three.js statically; result.js loads it with a dynamic
// import() so a missing three.js (or no WebGL) only disables this panel.

import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

const RADIUS = 1;
const HEIGHT = 4;
const SEGMENTS = 256;

/**
 * Light direction from azimuth/elevation in degrees. y is up (the trunk's
 * axis); azimuth 0 = from the viewer's side at the start (+z), 90 = from the right.
 */
function lightDirection(azimuthDeg, elevationDeg) {
  const az = THREE.MathUtils.degToRad(azimuthDeg);
  const el = THREE.MathUtils.degToRad(elevationDeg);
  return new THREE.Vector3(Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az));
}

/** Load a texture; resolves null for a missing URL. */
function loadTexture(loader, url, colour) {
  if (!url) return Promise.resolve(null);
  return loader.loadAsync(url).catch(() => {
    // the loader rejects with a DOM Event: turn it into a readable error
    throw new Error(`could not load ${url}`);
  }).then((texture) => {
    texture.wrapS = THREE.RepeatWrapping;
    texture.wrapT = THREE.RepeatWrapping;
    texture.colorSpace = colour ? THREE.SRGBColorSpace : THREE.NoColorSpace;
    texture.anisotropy = 8;
    return texture;
  });
}

/**
 * Normal (OpenGL, 8-bit RGBA) and displacement (8-bit, `low`..`high` to 0..255)
 * texel data of a height field in pixels, rows flipped to the bottom-up order a
 * DataTexture reads (an image texture is flipped on upload, a DataTexture not).
 */
function reliefTexels(height, width, rows, tile, low, high) {
  const normal = new Uint8Array(width * rows * 4);
  const disp = new Uint8Array(width * rows * 4);
  const span = high > low ? 255 / (high - low) : 0;
  const at = (x, y) => height[y * width + x];
  for (let y = 0; y < rows; y++) {
    const up = y > 0 ? y - 1 : tile ? rows - 1 : 0;
    const down = y < rows - 1 ? y + 1 : tile ? 0 : rows - 1;
    const out = (rows - 1 - y) * width * 4;
    for (let x = 0; x < width; x++) {
      const left = x > 0 ? x - 1 : tile ? width - 1 : 0;
      const right = x < width - 1 ? x + 1 : tile ? 0 : width - 1;
      // central differences (wrapping when the set tiles), one-sided at other borders
      const gx = (at(right, y) - at(left, y)) * (tile || (x > 0 && x < width - 1) ? 0.5 : 1);
      const gy = (at(x, down) - at(x, up)) * (tile || (y > 0 && y < rows - 1) ? 0.5 : 1);
      // OpenGL: x right, y up (rows run down), z out
      const nx = -gx;
      const ny = gy;
      const inv = 1 / Math.sqrt(nx * nx + ny * ny + 1);
      const i = out + x * 4;
      normal[i] = Math.round((nx * inv * 0.5 + 0.5) * 255);
      normal[i + 1] = Math.round((ny * inv * 0.5 + 0.5) * 255);
      normal[i + 2] = Math.round((inv * 0.5 + 0.5) * 255);
      normal[i + 3] = 255;
      const d = Math.max(0, Math.min(255, Math.round((at(x, y) - low) * span)));
      disp[i] = d;
      disp[i + 1] = d;
      disp[i + 2] = d;
      disp[i + 3] = 255;
    }
  }
  return { normal, disp };
}

function dataTexture(data, width, rows) {
  const texture = new THREE.DataTexture(data, width, rows, THREE.RGBAFormat);
  texture.wrapS = THREE.RepeatWrapping;
  texture.wrapT = THREE.RepeatWrapping;
  texture.colorSpace = THREE.NoColorSpace;
  texture.magFilter = THREE.LinearFilter;
  texture.minFilter = THREE.LinearMipmapLinearFilter;
  texture.generateMipmaps = true;
  texture.anisotropy = 8;
  texture.needsUpdate = true;
  return texture;
}

/**
 * Set up the trunk viewer.
 * @param {object} opts
 * @param {HTMLCanvasElement} opts.canvas
 * @param {object} opts.result   GET /api/results/{id} answer
 * @param {object} opts.controls {azimuth, elevation, displacement, repeat} range inputs
 * @param {(text:string)=>void} opts.onStatus  short messages for the panel
 * @returns {Promise<{dispose: Function}>}
 */
export async function initTrunk({ canvas, result, controls, onStatus }) {
  // Throws when WebGL is unavailable; the caller shows a message.
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.outputColorSpace = THREE.SRGBColorSpace;

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1a1b1d);

  const camera = new THREE.PerspectiveCamera(35, 1, 0.05, 100);
  camera.position.set(0, 0.3, 5.2);

  const orbit = new OrbitControls(camera, canvas);
  orbit.target.set(0, 0, 0);
  orbit.enableDamping = false; // render on demand: no inertia animation
  orbit.minDistance = 1.6;
  orbit.maxDistance = 14;
  // keep the view on the bark: no looking down into the open tube
  orbit.minPolarAngle = Math.PI / 2 - 0.6;
  orbit.maxPolarAngle = Math.PI / 2 + 0.6;
  const home = { position: camera.position.clone(), target: orbit.target.clone() };
  orbit.update();

  const sun = new THREE.DirectionalLight(0xffffff, 3.0);
  scene.add(sun);
  scene.add(new THREE.AmbientLight(0xffffff, 0.35));

  // Open-ended cylinder. The aoMap uses texture channel 0 (the `uv`
  // attribute) by default; a uv1 copy also serves a second-channel set-up.
  const geometry = new THREE.CylinderGeometry(RADIUS, RADIUS, HEIGHT, SEGMENTS, SEGMENTS, true);
  geometry.setAttribute("uv1", geometry.attributes.uv);

  // --- textures --------------------------------------------------------------
  onStatus("Loading textures…");
  const maps = result.maps || null;
  const colourUrl = (maps && maps.Color) || (result.files && result.files["texture.png"]);
  if (!colourUrl) throw new Error("This result has no texture to show.");
  const loader = new THREE.TextureLoader();
  const colourLoaded = loadTexture(loader, colourUrl, true).catch((err) => {
    renderer.dispose(); // free the WebGL context: the page will not use it
    throw err;
  });
  const [colour, normal, displacement, ao, roughness] = await Promise.all([
    colourLoaded,
    loadTexture(loader, maps && maps.NormalGL).catch(() => null),
    loadTexture(loader, maps && maps.Displacement).catch(() => null),
    loadTexture(loader, maps && maps.AmbientOcclusion).catch(() => null),
    loadTexture(loader, maps && maps.Roughness).catch(() => null),
  ]);
  const textures = [colour, normal, displacement, ao, roughness].filter(Boolean);

  const material = new THREE.MeshStandardMaterial({
    map: colour,
    normalMap: normal,
    displacementMap: displacement,
    aoMap: ao,
    roughnessMap: roughness,
    roughness: roughness ? 1.0 : 0.85,
    metalness: 0.0,
  });
  const trunk = new THREE.Mesh(geometry, material);
  scene.add(trunk);

  // Texel aspect of the texture (width / height).
  const image = colour.image;
  const aspect = image && image.width && image.height ? image.width / image.height : 1;

  // --- controls --------------------------------------------------------------
  const apply = () => {
    const az = Number(controls.azimuth.value);
    const el = Number(controls.elevation.value);
    sun.position.copy(lightDirection(az, el).multiplyScalar(10));

    // Relief: offset so the mean surface stays near the trunk's radius.
    const scale = displacement ? Number(controls.displacement.value) : 0;
    material.displacementScale = scale;
    material.displacementBias = -0.5 * scale;

    // u: `repeat` times round the trunk; v: as many as keep the texels square.
    const repeat = Math.max(1, Number(controls.repeat.value) || 1);
    const circumference = 2 * Math.PI * RADIUS;
    const repeatV = (HEIGHT * repeat * aspect) / circumference;
    for (const texture of textures) texture.repeat.set(repeat, repeatV);
  };

  const resize = () => {
    const width = canvas.clientWidth || 480;
    const height = canvas.clientHeight || 360;
    renderer.setSize(width, height, false);
    camera.aspect = width / height;
    camera.updateProjectionMatrix();
  };

  let pending = false;
  const render = () => {
    pending = false;
    renderer.render(scene, camera);
  };
  const requestRender = () => {
    if (pending) return;
    pending = true;
    requestAnimationFrame(render);
  };

  orbit.addEventListener("change", requestRender);
  const onInput = () => {
    apply();
    requestRender();
  };
  for (const input of [controls.azimuth, controls.elevation, controls.displacement, controls.repeat]) {
    input.addEventListener("input", onInput);
    input.addEventListener("change", onInput);
  }
  if (controls.reset) {
    controls.reset.addEventListener("click", () => {
      camera.position.copy(home.position);
      orbit.target.copy(home.target);
      orbit.update();
      requestRender();
    });
  }
  const observer = new ResizeObserver(() => {
    resize();
    requestRender();
  });
  observer.observe(canvas);

  // Say when displacement is not available (no material maps).
  if (!displacement) controls.displacement.disabled = true;

  // --- first frame -------------------------------------------------------------
  resize();
  apply();
  render();
  canvas.dataset.ready = "1";
  onStatus("");

  // The relief editor's heights: normals and displacement made here, the first
  // height's range mapped to the displacement's 0..1 (as the set's own map).
  let range = null;
  let edited = null; // {normal, disp}: the editor's textures, made once and refilled
  const setRelief = (height, width, rows, tile) => {
    if (!range) {
      let low = Infinity;
      let high = -Infinity;
      for (const v of height) {
        if (v < low) low = v;
        if (v > high) high = v;
      }
      range = [low, high];
    }
    const { normal: normalData, disp } = reliefTexels(height, width, rows, tile, range[0], range[1]);
    if (!edited || edited.normal.image.width !== width || edited.normal.image.height !== rows) {
      for (const old of [material.normalMap, material.displacementMap]) {
        if (!old) continue;
        old.dispose();
        textures.splice(textures.indexOf(old), 1);
      }
      edited = { normal: dataTexture(normalData, width, rows), disp: dataTexture(disp, width, rows) };
      material.normalMap = edited.normal;
      material.displacementMap = edited.disp;
      textures.push(edited.normal, edited.disp);
      material.needsUpdate = true;
      controls.displacement.disabled = false;
    } else {
      edited.normal.image.data = normalData;
      edited.disp.image.data = disp;
      edited.normal.needsUpdate = true;
      edited.disp.needsUpdate = true;
    }
    apply();
    renderer.render(scene, camera); // now: the caller times the edit up to this frame
  };

  return {
    render: requestRender,
    setRelief,
    dispose() {
      observer.disconnect();
      orbit.dispose();
      geometry.dispose();
      material.dispose();
      textures.forEach((t) => t.dispose());
      renderer.dispose();
    },
  };
}
