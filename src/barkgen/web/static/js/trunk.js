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

  return {
    render: requestRender,
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
